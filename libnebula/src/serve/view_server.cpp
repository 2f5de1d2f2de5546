// SPDX-License-Identifier: Apache-2.0
#include "nebula/serve/view_server.h"

#include "nebula/core/error.h"
#include "nebula/core/format.h"
#include "nebula/core/version.h"
#include "nebula/render/camera_model.h"
#include "nebula/serve/view_protocol.h"
#include "nebula/volume/block_walk.h"

#include <boost/asio/ip/tcp.hpp>
#include <boost/asio/post.hpp>
#include <boost/asio/strand.hpp>
#include <boost/beast/core.hpp>
#include <boost/beast/http.hpp>
#include <boost/beast/websocket.hpp>
#include <fmt/format.h>
#include <nlohmann/json.hpp>

#include <algorithm>
#include <atomic>
#include <chrono>
#include <condition_variable>
#include <deque>
#include <limits>
#include <map>
#include <mutex>
#include <optional>
#include <random>
#include <thread>

namespace nebula {

namespace beast = boost::beast;
namespace http = beast::http;
namespace websocket = beast::websocket;
namespace net = boost::asio;
using tcp = net::ip::tcp;
using nlohmann::json;

namespace {

/// Bytes of an HTTP request's header we read; the page's requests are far smaller.
constexpr std::size_t MAX_HTTP_HEADER = 8 * 1024;
/// Text messages waiting for one client; a client that lets more pile up is dropped.
constexpr std::size_t MAX_QUEUED_TEXT = 256;

std::string randomToken()
{
    std::random_device rd;
    std::string t;
    for (int i = 0; i < 4; ++i)
        t += fmt::format("{:08x}", std::uint32_t(rd()));
    return t;
}

/// Compares in time independent of where the strings differ.
bool sameToken(const std::string& a, const std::string& b)
{
    if (a.size() != b.size()) return false;
    unsigned char diff = 0;
    for (std::size_t i = 0; i < a.size(); ++i)
        diff |= static_cast<unsigned char>(a[i] ^ b[i]);
    return diff == 0;
}

/// The path of a request target and its "token" query parameter.
void splitTarget(const std::string& target, std::string& path, std::string& token)
{
    const auto q = target.find('?');
    path = target.substr(0, q);
    token.clear();
    if (q == std::string::npos) return;
    std::size_t i = q + 1;
    while (i <= target.size()) {
        std::size_t amp = target.find('&', i);
        if (amp == std::string::npos) amp = target.size();
        const std::string kv = target.substr(i, amp - i);
        if (kv.rfind("token=", 0) == 0) token = kv.substr(6);
        i = amp + 1;
    }
}

/// The "error" message answering request @p request ("" when it is not known).
std::string errorText(const std::string& request, const std::string& message)
{
    json j = {{"type", "error"}, {"message", message}};
    if (!request.empty()) j["request"] = request;
    return j.dump();
}

bool sameView(const Camera& a, const Camera& b)
{
    return cameraToJson(a) == cameraToJson(b);
}

bool sameShow(const ViewShow& a, const ViewShow& b)
{
    return a.single == b.single && a.field == b.field && a.emission == b.emission &&
           a.sprites == b.sprites && a.stars == b.stars;
}

bool sameTone(const ToneRequest& a, const ToneRequest& b)
{
    return a.automatic == b.automatic && a.exposure == b.exposure && a.gamma == b.gamma;
}

class WsSession;

/// The render thread: for each client its newest view, the stages still to render and the
/// best frame so far (to recompose when only the tone or the components change). Only the
/// newest view is kept: no queue builds up.
class Renderer
{
public:
    Renderer(const ViewSession& session, const Run& run, int jpegQuality)
        : mSession(session), mRun(run), mJpegQuality(jpegQuality)
    {
        mRun.setCancel(&mCancel);
        mThread = std::thread([this] { loop(); });
    }
    ~Renderer() { stop(); }

    void stop()
    {
        {
            const std::lock_guard<std::mutex> lock(mMutex);
            mStopping = true;
            mCancel = true;
        }
        mWake.notify_all();
        if (mThread.joinable()) mThread.join();
    }

    /// A client's new view: replaces the one before, cancels its frame in flight.
    void submit(const std::shared_ptr<WsSession>& client, const ViewRequest& view);
    /// The client's last view (for the probe); false if none yet.
    bool lastView(const WsSession* client, ViewRequest& view)
    {
        const std::lock_guard<std::mutex> lock(mMutex);
        const auto it = mSlots.find(client);
        if (it == mSlots.end()) return false;
        view = it->second.view;
        return true;
    }
    void remove(const WsSession* client)
    {
        const std::lock_guard<std::mutex> lock(mMutex);
        mSlots.erase(client);
        if (mCurrent == client) mCancel = true;
    }

private:
    struct Slot
    {
        std::weak_ptr<WsSession> client;
        ViewRequest view;
        std::uint64_t serial = 0; ///< counts views: a result for an older one is not kept
        int next = 0;             ///< the next stage to render; 3: none
        int last = 2;             ///< the last stage to render for this view
        bool recompose = false;   ///< the best frame again with the new tone or components
        std::shared_ptr<const ViewFrame> best;
        std::chrono::steady_clock::time_point arrived; ///< when the view came (for -v)
    };

    void loop();
    void send(const std::shared_ptr<WsSession>& client, const ViewRequest& view,
              const ViewFrame& frame, std::chrono::steady_clock::time_point arrived);

    const ViewSession& mSession;
    Run mRun; ///< the render's, with the cancel flag
    int mJpegQuality;
    std::mutex mMutex;
    std::condition_variable mWake;
    std::map<const WsSession*, Slot> mSlots;
    const WsSession* mCurrent = nullptr;
    ViewStage mCurrentStage = ViewStage::Interactive;
    std::atomic<bool> mCancel{false};
    bool mStopping = false;
    std::size_t mTurn = 0; ///< round robin over the clients
    std::thread mThread;
};

} // namespace

struct ViewServer::Impl
{
    const ViewSession& session;
    ViewServerOptions options;
    Run run;
    net::io_context ioc{1};
    tcp::acceptor acceptor{ioc};
    std::unique_ptr<Renderer> renderer;
    std::atomic<int> clients{0};
    std::vector<std::string> starNames;
    std::string hello; ///< the hello message (the same for every client)

    Impl(const ViewSession& s, const ViewServerOptions& o, const Run& r)
        : session(s), options(o), run(r)
    {}
    void accept();
};

namespace {

/// One WebSocket client: reads its messages, writes its frames and answers. All its
/// handlers run on the I/O thread; the render thread hands it frames through post().
class WsSession : public std::enable_shared_from_this<WsSession>
{
public:
    WsSession(tcp::socket&& socket, ViewServer::Impl& server)
        : mWs(std::move(socket)), mServer(server)
    {
        ++mServer.clients;
    }
    ~WsSession() { --mServer.clients; }

    void start(http::request<http::string_body> req)
    {
        mWs.set_option(websocket::stream_base::timeout::suggested(beast::role_type::server));
        mWs.read_message_max(MAX_CLIENT_MESSAGE);
        mWs.async_accept(req, [self = shared_from_this()](beast::error_code ec) {
            if (ec) return;
            self->sendText(self->mServer.hello);
            self->read();
        });
    }

    /// Queues a text message (I/O thread).
    void sendText(std::string text)
    {
        if (mClosed) return;
        if (mQueue.size() >= MAX_QUEUED_TEXT) { // the client does not read: drop it
            close(websocket::close_code::policy_error, "not reading");
            return;
        }
        mQueue.push_back({std::make_shared<const std::string>(std::move(text)), false});
        write();
    }

    /// Queues a frame (I/O thread): replaces a frame that has not started to go out, so a
    /// slow client gets the newest frame, never a backlog.
    void sendFrame(std::shared_ptr<const std::string> frame)
    {
        if (mClosed) return;
        mPendingFrame = std::move(frame); // waits only while a write is under way
        write();
    }

    /// Posts a text message from the render thread.
    static void postText(const std::shared_ptr<WsSession>& self, std::string text)
    {
        net::post(self->mWs.get_executor(),
                  [self, t = std::move(text)]() mutable { self->sendText(std::move(t)); });
    }

    /// Posts a frame from the render thread.
    static void post(const std::shared_ptr<WsSession>& self, std::shared_ptr<const std::string> f)
    {
        net::post(self->mWs.get_executor(),
                  [self, f = std::move(f)]() mutable { self->sendFrame(std::move(f)); });
    }

private:
    struct Out
    {
        std::shared_ptr<const std::string> data;
        bool binary = false;
    };

    void read()
    {
        mWs.async_read(mBuffer, [self = shared_from_this()](beast::error_code ec, std::size_t) {
            self->onRead(ec);
        });
    }

    void onRead(beast::error_code ec)
    {
        if (ec) { // closed, timed out, or too big (Beast closes with 1009)
            finish();
            return;
        }
        if (!mWs.got_text()) {
            close(websocket::close_code::bad_payload, "binary messages are not accepted");
            return;
        }
        const std::string text = beast::buffers_to_string(mBuffer.data());
        mBuffer.consume(mBuffer.size());
        try {
            handle(text);
        } catch (const MalformedMessage& e) {
            close(websocket::close_code::bad_payload, e.what());
            return;
        } catch (const std::exception& e) {
            sendText(errorText("", e.what()));
        }
        if (!mClosed) read();
    }

    void handle(const std::string& text);

    void write()
    {
        if (mWriting || mClosed) return;
        Out out;
        if (!mQueue.empty()) { // answers first: they are small
            out = mQueue.front();
            mQueue.pop_front();
        } else if (mPendingFrame) {
            out = {std::move(mPendingFrame), true};
            mPendingFrame.reset();
        } else {
            return;
        }
        mWriting = true;
        mWs.binary(out.binary);
        mWs.async_write(net::buffer(*out.data), [self = shared_from_this(), keep = out.data](
                                                    beast::error_code ec, std::size_t) {
            self->mWriting = false;
            if (ec) {
                self->finish();
                return;
            }
            self->write();
        });
    }

    void close(websocket::close_code code, const std::string& why)
    {
        if (mClosed) return;
        mClosed = true;
        mServer.run.info("client closed (" + why.substr(0, 200) + ")");
        mServer.renderer->remove(this);
        websocket::close_reason reason(code, why.substr(0, 120));
        mWs.async_close(reason, [self = shared_from_this()](beast::error_code) {});
    }

    void finish()
    {
        if (!mClosed) {
            mClosed = true;
            mServer.renderer->remove(this);
        }
    }

    websocket::stream<beast::tcp_stream> mWs;
    ViewServer::Impl& mServer;
    beast::flat_buffer mBuffer;
    std::deque<Out> mQueue;
    std::shared_ptr<const std::string> mPendingFrame;
    bool mWriting = false;
    bool mClosed = false;
};

void WsSession::handle(const std::string& text)
{
    const ViewSession& session = mServer.session;
    const Camera& base = session.settings().render.camera;
    const std::string pathName =
        mServer.options.pathOut.empty() ? "camera path" : mServer.options.pathOut;
    const ClientMessage m = parseClientMessage(text, mServer.starNames, base, pathName);
    switch (m.kind) {
    case ClientMessage::Kind::View: mServer.renderer->submit(shared_from_this(), m.view); break;
    case ClientMessage::Kind::Probe: {
        ViewRequest last;
        if (!mServer.renderer->lastView(this, last)) {
            throw Error("probe: no view yet (send a view first)");
        }
        const Camera c = session.stageOptions(last.camera, ViewStage::Final, false).camera;
        if (!(m.x >= 0 && m.x <= c.width && m.y >= 0 && m.y <= c.height)) {
            throw Error(fmt::format("probe: ({:g}, {:g}) is outside the {}x{} image", m.x, m.y,
                                    c.width, c.height));
        }
        const ProbeResult p = session.probe(c, m.x, m.y);
        json tau = json::object();
        for (std::size_t s = 0; s < p.tau.size(); ++s)
            tau[mServer.starNames[s]] = p.tau[s];
        json r = {{"type", "probe"}, {"x", m.x}, {"y", m.y}, {"hit", p.hit}, {"tau_ray", p.tauRay}};
        if (p.hit) {
            r["position"] = {p.position.x, p.position.y, p.position.z};
            r["density"] = p.density;
            r["tau"] = tau;
            r["J"] = p.J.empty() ? json(nullptr) : json(p.J);
        }
        sendText(r.dump());
        break;
    }
    case ClientMessage::Kind::Scrub: {
        ViewRequest view; // the look of the last view, with the path's camera
        Camera model = base;
        if (mServer.renderer->lastView(this, view)) { // its model and parameters, base's size
            model = view.camera;
            model.width = base.width;
            model.height = base.height;
        }
        const Camera c = m.path.at(m.time, model);
        (void)Projection(c); // a created camera is valid
        sendText(json({{"type", "camera"}, {"camera", cameraJson(c)}, {"time", m.time}}).dump());
        view.camera = c;
        view.moving = true;
        view.id = std::max(view.id, m.view.id);
        mServer.renderer->submit(shared_from_this(), view);
        break;
    }
    case ClientMessage::Kind::LoadPath: {
        const std::string name = m.name.empty() ? "the loaded path" : m.name;
        try {
            const CameraPath path = parseCameraPath(m.text, name, base);
            sendText(json({{"type", "path"}, {"path", pathJson(path)}}).dump());
        } catch (const Error& e) {
            sendText(errorText("load_path", e.what()));
        }
        break;
    }
    case ClientMessage::Kind::SavePath: {
        const std::string& file = mServer.options.pathOut;
        try {
            if (file.empty()) throw Error("save: nebview was started without --path-out");
            writeCameraPath(file, m.path);
            mServer.run.info("wrote " + file);
            // How to render it: the frame count and rate the fly-through target needs.
            const long frames = m.path.frameCount();
            sendText(json({{"type", "saved"},
                           {"file", file},
                           {"keyframes", m.path.keys.size()},
                           {"frames", frames},
                           {"fps", m.path.fps},
                           {"render", fmt::format("make -f Makefile.data flythrough FLY_PATH={} "
                                                  "FLY_FRAMES={} FLY_FPS={:g}",
                                                  file, frames, m.path.fps)}})
                         .dump());
        } catch (const Error& e) {
            sendText(errorText("save_path", e.what()));
        }
        break;
    }
    }
}

void Renderer::submit(const std::shared_ptr<WsSession>& client, const ViewRequest& view)
{
    {
        const std::lock_guard<std::mutex> lock(mMutex);
        Slot& slot = mSlots[client.get()];
        slot.client = client;
        const bool sameCamera = slot.best && sameView(slot.view.camera, view.camera) &&
                                slot.view.spectral == view.spectral;
        const bool looks = !sameShow(slot.view.show, view.show) ||
                           !sameTone(slot.view.tone, view.tone) || slot.view.png != view.png;
        const int done = sameCamera ? int(slot.best->stage) : -1;
        slot.view = view;
        slot.arrived = std::chrono::steady_clock::now();
        ++slot.serial;
        slot.last = view.moving ? 0 : 2;
        slot.next = done + 1;
        if (sameCamera && slot.next > slot.last) slot.next = 3; // nothing more to render
        slot.recompose = sameCamera && (looks || slot.next > slot.last);
        if (!sameCamera) slot.best.reset();
        // A newer view wins: a preview or final frame in flight is cancelled at once; an
        // interactive one (a fraction of a second) is finished and sent, so that a camera
        // moving faster than frames render still gets frames, each of the newest view.
        if (mCurrent == client.get() && mCurrentStage != ViewStage::Interactive) mCancel = true;
    }
    mWake.notify_all();
}

void Renderer::loop()
{
    std::unique_lock<std::mutex> lock(mMutex);
    while (!mStopping) {
        // The next client with work, in turn.
        Slot* pick = nullptr;
        const WsSession* key = nullptr;
        if (!mSlots.empty()) {
            auto it = mSlots.begin();
            std::advance(it, std::ptrdiff_t(mTurn % mSlots.size()));
            for (std::size_t n = 0; n < mSlots.size(); ++n) {
                Slot& s = it->second;
                if (s.recompose || s.next <= s.last) {
                    pick = &s;
                    key = it->first;
                    break;
                }
                if (++it == mSlots.end()) it = mSlots.begin();
            }
        }
        if (!pick) {
            mWake.wait(lock);
            continue;
        }
        ++mTurn;
        const ViewRequest view = pick->view;
        const auto arrived = pick->arrived;
        const std::uint64_t serial = pick->serial;
        const auto client = pick->client.lock();
        if (!client) {
            mSlots.erase(key);
            continue;
        }
        if (pick->recompose) { // the best frame with the new look: no render
            pick->recompose = false;
            const auto best = pick->best;
            lock.unlock();
            send(client, view, *best, arrived);
            lock.lock();
            continue;
        }
        const auto stage = ViewStage(pick->next);
        mCurrent = key;
        mCurrentStage = stage;
        mCancel = false;
        lock.unlock();
        std::shared_ptr<ViewFrame> frame;
        std::string failure;
        try {
            frame = std::make_shared<ViewFrame>(
                mSession.render(view.camera, stage, view.spectral, mRun));
        } catch (const Cancelled&) {
        } catch (const std::exception& e) {
            failure = e.what();
        }
        lock.lock();
        mCurrent = nullptr;
        const auto it = mSlots.find(key);
        if (it == mSlots.end()) continue;
        Slot& slot = it->second;
        if (!failure.empty()) {
            if (slot.serial == serial) slot.next = 3;
            lock.unlock();
            WsSession::postText(client, errorText("view", failure));
            lock.lock();
            continue;
        }
        if (!frame) continue; // cancelled: the newer view is in the slot
        if (slot.serial == serial) {
            slot.best = frame;
            slot.next = int(stage) + 1;
        }
        lock.unlock();
        send(client, view, *frame, arrived);
        lock.lock();
    }
}

void Renderer::send(const std::shared_ptr<WsSession>& client, const ViewRequest& view,
                    const ViewFrame& frame, std::chrono::steady_clock::time_point arrived)
{
    try {
        const Image img = mSession.compose(frame, view.show);
        const ToneCurve curve = requestTone(img, view.tone, mSession.settings().tone);
        std::string bytes;
        if (view.png) {
            bytes = pngBytes(img, curve);
        } else {
            bytes = jpegBytes(displayPixels(img, curve), img.width, img.height, mJpegQuality);
        }
        const json header = {{"type", "frame"},
                             {"id", view.id},
                             {"width", img.width},
                             {"height", img.height},
                             {"format", view.png ? "png" : "jpeg"},
                             {"stage", toString(frame.stage)},
                             {"render_ms", frame.seconds * 1e3},
                             {"samples", frame.stats.samples},
                             {"white", curve.white},
                             {"gamma", curve.gamma},
                             {"camera", cameraJson(frame.camera)}};
        const std::string h = header.dump();
        auto message = std::make_shared<std::string>();
        message->reserve(4 + h.size() + bytes.size());
        const std::uint32_t n = std::uint32_t(h.size());
        for (int i = 0; i < 4; ++i)
            message->push_back(char((n >> (8 * i)) & 0xff));
        *message += h;
        *message += bytes;
        const std::size_t size = message->size();
        WsSession::post(client, std::move(message));
        if (mRun.verbosity().verbose > 0) {
            mRun.info(fmt::format(
                "view {} {} {}x{}: render {:.1f} ms, out {:.1f} ms after the view came, {} bytes",
                view.id, toString(frame.stage), img.width, img.height, frame.seconds * 1e3,
                std::chrono::duration<double, std::milli>(std::chrono::steady_clock::now() -
                                                          arrived)
                    .count(),
                size));
        }
    } catch (const std::exception& e) {
        mRun.warn(std::string("a frame could not be sent: ") + e.what());
    }
}

} // namespace

namespace {

/// One HTTP connection: the page, or the upgrade to a WebSocket; 403 without the token.
class HttpSession : public std::enable_shared_from_this<HttpSession>
{
public:
    HttpSession(tcp::socket&& socket, ViewServer::Impl& server)
        : mStream(std::move(socket)), mServer(server)
    {}

    void start()
    {
        mParser.emplace();
        mParser->header_limit(std::uint32_t(MAX_HTTP_HEADER));
        mParser->body_limit(1024);
        mStream.expires_after(std::chrono::seconds(10)); // a client that sends nothing goes
        http::async_read(
            mStream, mBuffer, *mParser,
            [self = shared_from_this()](beast::error_code ec, std::size_t) { self->onRead(ec); });
    }

private:
    void onRead(beast::error_code ec)
    {
        if (ec) { // closed, timed out, or a request over the limits
            if (ec != http::error::end_of_stream) reply(http::status::bad_request, "bad request\n");
            return;
        }
        http::request<http::string_body> req = mParser->release();
        std::string path, token;
        splitTarget(std::string(req.target()), path, token);
        if (!sameToken(token, mServer.options.token)) {
            reply(http::status::forbidden, "403: this viewer needs its access token (the URL "
                                           "nebview printed)\n");
            return;
        }
        // DNS rebinding: a page whose name resolves to this machine is not this server's.
        const std::string host(req[http::field::host]);
        const std::uint16_t port = mServer.acceptor.local_endpoint().port();
        if (!hostAllowed(host, mServer.options.address, port)) {
            reply(http::status::forbidden,
                  "403: this viewer answers to the address nebview printed, not \"" +
                      detail::printable(host, 80) + "\"\n");
            return;
        }
        mHost = host;
        if (websocket::is_upgrade(req)) {
            // Cross-site WebSocket hijacking: only the viewer's own page may connect.
            const std::string origin(req[http::field::origin]);
            if (!originAllowed(origin, mServer.options.address, port)) {
                reply(http::status::forbidden,
                      "403: WebSocket connections come from the viewer's own page only, not "
                      "from \"" +
                          detail::printable(origin, 80) + "\"\n");
                return;
            }
            if (path != "/ws") {
                reply(http::status::not_found, "404\n");
                return;
            }
            if (mServer.clients.load() >= mServer.options.maxClients) {
                reply(http::status::service_unavailable,
                      fmt::format("503: {} viewers are connected already\n",
                                  mServer.options.maxClients));
                return;
            }
            mStream.expires_never();
            std::make_shared<WsSession>(mStream.release_socket(), mServer)->start(std::move(req));
            return;
        }
        if (req.method() != http::verb::get && req.method() != http::verb::head) {
            reply(http::status::method_not_allowed, "405\n");
            return;
        }
        if (path != "/" && path != "/index.html") {
            reply(http::status::not_found, "404\n");
            return;
        }
        reply(http::status::ok, viewerPage(), "text/html; charset=utf-8",
              req.method() == http::verb::head);
    }

    void reply(http::status status, const std::string& body,
               const char* type = "text/plain; charset=utf-8", bool head = false)
    {
        auto res = std::make_shared<http::response<http::string_body>>(status, 11);
        res->set(http::field::server, std::string("nebview ") + NEBULA_VERSION_STRING);
        res->set(http::field::content_type, type);
        res->set(http::field::cache_control, "no-store");
        // The page runs only its own inline script and talks only to this server: its own
        // host and port, by the name the browser used (hostAllowed() checked it).
        const std::uint16_t port = mServer.acceptor.local_endpoint().port();
        std::string self = mHost.empty() ? mServer.options.address : mHost;
        if (self.find(':') != std::string::npos && self.front() != '[' &&
            std::count(self.begin(), self.end(), ':') > 1)
            self = "[" + self + "]"; // an IPv6 listening address
        if (self.back() == ']' || self.find(':') == std::string::npos)
            self += ":" + std::to_string(port);
        res->set("Content-Security-Policy",
                 "default-src 'none'; script-src 'unsafe-inline'; style-src 'unsafe-inline'; "
                 "img-src blob: data:; connect-src ws://" +
                     self + "; base-uri 'none'; form-action 'none'; frame-ancestors 'none'");
        res->set("X-Content-Type-Options", "nosniff");
        res->keep_alive(false);
        if (!head) res->body() = body;
        res->prepare_payload();
        if (head) res->content_length(body.size());
        mStream.expires_after(std::chrono::seconds(10));
        http::async_write(mStream, *res,
                          [self = shared_from_this(), res](beast::error_code, std::size_t) {
                              beast::error_code ignored;
                              self->mStream.socket().shutdown(tcp::socket::shutdown_send, ignored);
                          });
    }

    beast::tcp_stream mStream;
    ViewServer::Impl& mServer;
    std::string mHost; ///< the request's Host header, once hostAllowed() passed it
    beast::flat_buffer mBuffer;
    std::optional<http::request_parser<http::string_body>> mParser;
};

} // namespace

void ViewServer::Impl::accept()
{
    acceptor.async_accept(net::make_strand(ioc), [this](beast::error_code ec, tcp::socket socket) {
        if (ec == net::error::operation_aborted) return; // stopped
        if (!ec) std::make_shared<HttpSession>(std::move(socket), *this)->start();
        accept();
    });
}

ViewServer::ViewServer(const ViewSession& session, const ViewServerOptions& options, const Run& run)
    : mImpl(std::make_unique<Impl>(session, options, run))
{
    Impl& s = *mImpl;
    if (s.options.token.empty()) s.options.token = randomToken();
    if (!(s.options.jpegQuality >= 1 && s.options.jpegQuality <= 100)) {
        throw UsageError("--jpeg-quality must be in [1, 100]");
    }
    const std::string where = fmt::format("{}:{}", s.options.address, s.options.port);
    beast::error_code ec;
    const auto address = net::ip::make_address(s.options.address, ec);
    if (ec)
        throw UsageError("--listen " + where + ": \"" + s.options.address +
                         "\" is not an IP address");
    const tcp::endpoint endpoint(address, s.options.port);
    s.acceptor.open(endpoint.protocol(), ec);
    if (!ec) s.acceptor.set_option(net::socket_base::reuse_address(true), ec);
    if (!ec) s.acceptor.bind(endpoint, ec);
    if (ec) {
        const std::string why = ec == net::error::address_in_use
                                    ? "the port is in use (another nebview?); choose another "
                                      "with --port, or --port 0 for a free one"
                                    : ec.message();
        throw Error("cannot listen on " + where + ": " + why);
    }
    s.acceptor.listen(net::socket_base::max_listen_connections, ec);
    if (ec) throw Error("cannot listen on " + where + ": " + ec.message());

    for (const auto& star : session.scene().stars)
        s.starNames.push_back(star.name);
    // What every client is told first.
    const SparseVolume& f = session.scene().fields;
    Vec3 lo(std::numeric_limits<double>::infinity(), std::numeric_limits<double>::infinity(),
            std::numeric_limits<double>::infinity());
    Vec3 hi = lo * -1.0;
    for (int c = 0; c < 8; ++c) {
        const Vec3 p = f.cornerWorld(c);
        lo = Vec3(std::min(lo.x, p.x), std::min(lo.y, p.y), std::min(lo.z, p.z));
        hi = Vec3(std::max(hi.x, p.x), std::max(hi.y, p.y), std::max(hi.z, p.z));
    }
    json stars = json::array();
    for (const auto& star : session.scene().stars)
        stars.push_back({{"name", star.name}, {"position", star.position}});
    const auto full = session.resolution(ViewStage::Final);
    const auto fast = session.resolution(ViewStage::Interactive);
    const ToneParams& tone = session.settings().tone;
    json cameraNames = json::array(); // the registered models, for the page's controls
    for (const CameraModel* m : cameraModels()) {
        cameraNames.push_back({{"name", m->name()},
                               {"uses_fov", m->usesFov(Camera{})},
                               {"fov_max", m->maxFov()},
                               {"parameters", m->parameters()}});
    }
    json hello = {
        {"type", "hello"},
        {"version", NEBULA_VERSION_STRING},
        {"input", session.grids().source},
        {"box", {{"min", {lo.x, lo.y, lo.z}}, {"max", {hi.x, hi.y, hi.z}}}},
        {"voxel_pc", voxelSize(f.indexToWorld)},
        {"stars", stars},
        {"spectral", true},
        {"field", session.hasField()},
        {"emission", session.hasEmission()},
        {"camera", cameraJson(session.settings().render.camera)},
        {"cameras", cameraNames},
        {"width", full[0]},
        {"height", full[1]},
        {"interactive", {{"width", fast[0]}, {"height", fast[1]}}},
        {"tone",
         {{"auto", tone.automatic},
          {"exposure", tone.automatic ? 0.0 : tone.exposure},
          {"gamma", tone.fixedGamma || !tone.automatic ? json(tone.gamma) : json(nullptr)}}},
        {"path", s.options.path ? pathJson(*s.options.path) : json(nullptr)},
        {"path_out", s.options.pathOut.empty() ? json(nullptr) : json(s.options.pathOut)}};
    s.hello = hello.dump();
    s.renderer = std::make_unique<Renderer>(session, run, s.options.jpegQuality);
}

ViewServer::~ViewServer()
{
    stop();
    if (mImpl->renderer) mImpl->renderer->stop();
}

std::uint16_t ViewServer::port() const
{
    return mImpl->acceptor.local_endpoint().port();
}

std::string ViewServer::url() const
{
    std::string host = mImpl->options.address;
    if (host.find(':') != std::string::npos) host = "[" + host + "]"; // IPv6
    return fmt::format("http://{}:{}/?token={}", host, port(), mImpl->options.token);
}

const std::string& ViewServer::token() const
{
    return mImpl->options.token;
}

void ViewServer::run()
{
    mImpl->accept();
    mImpl->ioc.run();
}

void ViewServer::stop()
{
    mImpl->ioc.stop();
}

} // namespace nebula
