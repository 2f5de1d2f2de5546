// SPDX-License-Identifier: Apache-2.0
// nebview's server, spoken to as a browser would (Beast clients): the token, the embedded
// page only, frames at three stages with the final one nebrender's image, bad messages that
// close only their own connection, a client that stops reading, two clients, the probe and
// the camera path's save and load.
#include "nebula/core/error.h"
#include "nebula/render/camera_model.h"
#include "nebula/render/fast.h"
#include "nebula/serve/view_protocol.h"
#include "nebula/serve/view_server.h"
#include "nebula/stages/scene_assembly.h"
#include "test_util.h"
#include "view_scene.h"

#include <boost/asio/ip/tcp.hpp>
#include <boost/beast/core.hpp>
#include <boost/beast/http.hpp>
#include <boost/beast/websocket.hpp>
#include <gtest/gtest.h>
#include <nlohmann/json.hpp>

#include <chrono>
#include <fstream>
#include <thread>

using namespace nebula;
namespace beast = boost::beast;
namespace http = beast::http;
namespace websocket = beast::websocket;
namespace net = boost::asio;
using tcp = net::ip::tcp;
using nlohmann::json;

namespace {

const std::shared_ptr<const GridSet>& cube()
{
    static const auto grids = test::litCube();
    return grids;
}

/// A server on a free loopback port, run on its own thread for the test's lifetime.
class Served
{
public:
    explicit Served(const ViewSettings& settings, std::string pathOut = "")
        : session(cube(), settings, cube()->dust(Run()), Run())
    {
        ViewServerOptions o;
        o.pathOut = std::move(pathOut);
        server = std::make_unique<ViewServer>(session, o, Run());
        thread = std::thread([this] { server->run(); });
    }
    ~Served()
    {
        server->stop();
        thread.join();
    }
    ViewSession session;
    std::unique_ptr<ViewServer> server;
    std::thread thread;
};

struct Reply
{
    int status = 0;
    std::string body;
};

Reply get(std::uint16_t port, const std::string& target, http::verb verb = http::verb::get)
{
    net::io_context ioc;
    tcp::socket s(ioc);
    s.connect({net::ip::address_v4::loopback(), port});
    http::request<http::string_body> req{verb, target, 11};
    req.set(http::field::host, "127.0.0.1");
    req.prepare_payload();
    http::write(s, req);
    beast::flat_buffer b;
    http::response<http::string_body> res;
    http::read(s, b, res);
    return {int(res.result_int()), res.body()};
}

/// The status of a WebSocket upgrade of @p target with Host @p host and Origin @p origin
/// ("": none), as a browser sends it.
unsigned upgradeStatus(std::uint16_t port, const std::string& target, const std::string& host,
                       const std::string& origin)
{
    net::io_context ioc;
    tcp::socket sock(ioc);
    sock.connect({net::ip::address_v4::loopback(), port});
    http::request<http::empty_body> req{http::verb::get, target, 11};
    req.set(http::field::host, host);
    if (!origin.empty()) req.set(http::field::origin, origin);
    req.set(http::field::connection, "Upgrade");
    req.set(http::field::upgrade, "websocket");
    req.set(http::field::sec_websocket_version, "13");
    req.set(http::field::sec_websocket_key, "dGhlIHNhbXBsZSBub25jZQ==");
    http::write(sock, req);
    beast::flat_buffer b;
    http::response<http::string_body> res;
    http::read(sock, b, res);
    return res.result_int();
}

struct Frame
{
    json header;
    std::string image;
};

/// A WebSocket client of the viewer.
class Client
{
public:
    Client(std::uint16_t port, const std::string& token, int receiveBuffer = 0)
    {
        ws.next_layer().open(tcp::v4());
        if (receiveBuffer > 0) {
            ws.next_layer().set_option(net::socket_base::receive_buffer_size(receiveBuffer));
        }
        ws.next_layer().connect({net::ip::address_v4::loopback(), port});
        ws.handshake(response, "127.0.0.1", "/ws?token=" + token);
    }
    void send(const json& j)
    {
        ws.text(true);
        ws.write(net::buffer(j.dump()));
    }
    /// The next message: text into @p text, or a frame into @p frame; false if closed.
    bool next(json* text, Frame* frame)
    {
        beast::flat_buffer b;
        beast::error_code ec;
        ws.read(b, ec);
        if (ec) return false;
        const std::string m = beast::buffers_to_string(b.data());
        if (ws.got_text()) {
            if (text) *text = json::parse(m);
            return true;
        }
        const std::uint32_t n =
            std::uint32_t(std::uint8_t(m[0])) | std::uint32_t(std::uint8_t(m[1])) << 8 |
            std::uint32_t(std::uint8_t(m[2])) << 16 | std::uint32_t(std::uint8_t(m[3])) << 24;
        if (frame) {
            frame->header = json::parse(m.substr(4, n));
            frame->image = m.substr(4 + n);
        }
        return true;
    }
    /// Text messages until one of @p type (skipping frames and others).
    json until(const std::string& type)
    {
        json t;
        Frame f;
        while (true) {
            t = nullptr;
            if (!next(&t, &f)) throw std::runtime_error("closed before a \"" + type + "\"");
            if (!t.is_null() && t["type"] == type) return t;
        }
    }
    /// Frames until one of @p stage for view @p id; the stages seen on the way into @p seen.
    Frame frameAt(const std::string& stage, long long id, std::vector<std::string>* seen = nullptr)
    {
        while (true) {
            json t;
            Frame f;
            if (!next(&t, &f)) throw std::runtime_error("closed before the frame");
            if (!t.is_null()) {
                if (t["type"] == "error") throw std::runtime_error(t.dump());
                continue;
            }
            if (f.header["id"] != id) continue;
            if (seen) seen->push_back(f.header["stage"]);
            if (f.header["stage"] == stage) return f;
        }
    }
    websocket::response_type response;
    net::io_context ioc;
    websocket::stream<tcp::socket> ws{ioc};
};

json viewMessage(long long id, const Camera& c, bool moving, const std::string& format = "png")
{
    return {{"type", "view"},
            {"id", id},
            {"camera", cameraJson(c)},
            {"moving", moving},
            {"format", format}};
}

} // namespace

TEST(ViewServer, EveryRequestNeedsTheTokenAndOnlyThePageIsServed)
{
    Served s(test::cubeSettings());
    const auto port = s.server->port();
    const std::string t = s.server->token();
    EXPECT_EQ(t.size(), 32u);
    EXPECT_EQ(get(port, "/").status, 403);
    EXPECT_EQ(get(port, "/?token=" + std::string(32, '0')).status, 403);
    EXPECT_EQ(get(port, "/?token=" + t.substr(0, 31)).status, 403);
    const Reply page = get(port, "/?token=" + t);
    EXPECT_EQ(page.status, 200);
    EXPECT_EQ(page.body, viewerPage());
    EXPECT_TRUE(test::contains(page.body, "<html"));
    EXPECT_EQ(get(port, "/index.html?token=" + t).status, 200);
    // No path from the URL reaches the file system.
    for (const std::string target :
         {"/../../../../etc/passwd", "/%2e%2e/%2e%2e/etc/passwd", "/etc/passwd", "//etc/passwd",
          "/index.html/../../etc/passwd", "/CMakeCache.txt"}) {
        const Reply r = get(port, target + "?token=" + t);
        EXPECT_EQ(r.status, 404) << target;
        EXPECT_FALSE(test::contains(r.body, "root:")) << target;
    }
    EXPECT_EQ(get(port, "/../../etc/passwd").status, 403); // no token: 403 first
    EXPECT_EQ(get(port, "/?token=" + t, http::verb::post).status, 405);
    // The WebSocket too.
    EXPECT_THROW(Client(port, "wrong"), beast::system_error);
    try {
        Client c(port, "wrong");
    } catch (const beast::system_error&) {
    }
    for (const std::string& target :
         std::vector<std::string>{"/ws?token=nope", "/ws", "/ws?token=" + t + "x"}) {
        EXPECT_EQ(upgradeStatus(port, target, "127.0.0.1", ""), 403u) << target;
    }
}

// Cross-site WebSocket hijacking and DNS rebinding: another site's page, or a page under a
// name that resolves to this machine, cannot talk to the viewer even with the token; the CSP
// lets the page connect to its own host and port only.
TEST(ViewServer, OnlyItsOwnPageMayConnect)
{
    Served s(test::cubeSettings(16, 16));
    const std::uint16_t port = s.server->port();
    const std::string t = s.server->token(), p = std::to_string(port);
    EXPECT_EQ(upgradeStatus(port, "/ws?token=" + t, "127.0.0.1:" + p, "http://127.0.0.1:" + p),
              101u);
    EXPECT_EQ(upgradeStatus(port, "/ws?token=" + t, "localhost:" + p, "http://localhost:" + p),
              101u);
    EXPECT_EQ(upgradeStatus(port, "/ws?token=" + t, "127.0.0.1:" + p, ""), 101u); // not a browser
    for (const std::string& origin : std::vector<std::string>{
             "http://evil.example", "http://evil.example:" + p, "null", "https://127.0.0.1:" + p,
             "http://127.0.0.1", "http://127.0.0.1:" + std::to_string(port + 1),
             "http://127.0.0.1:" + p + "/x", "file://"}) {
        EXPECT_EQ(upgradeStatus(port, "/ws?token=" + t, "127.0.0.1:" + p, origin), 403u) << origin;
    }
    for (const std::string& host :
         std::vector<std::string>{"evil.example:" + p, "evil.example",
                                  "127.0.0.1:" + std::to_string(port + 1), "", "127.0.0.1:"}) {
        EXPECT_EQ(upgradeStatus(port, "/ws?token=" + t, host, "http://" + host), 403u) << host;
    }
    // The page's policy names the server's own address, not every ws: URL.
    net::io_context ioc;
    tcp::socket sock(ioc);
    sock.connect({net::ip::address_v4::loopback(), port});
    http::request<http::string_body> req{http::verb::get, "/?token=" + t, 11};
    req.set(http::field::host, "127.0.0.1:" + p);
    http::write(sock, req);
    beast::flat_buffer b;
    http::response<http::string_body> res;
    http::read(sock, b, res);
    const std::string csp(res["Content-Security-Policy"]);
    EXPECT_TRUE(test::contains(csp, "connect-src ws://127.0.0.1:" + p + ";")) << csp;
    EXPECT_FALSE(test::contains(csp, "ws: ")) << csp;
}

TEST(ViewProtocol, HostAndOriginAreTheServersOwn)
{
    EXPECT_TRUE(hostAllowed("127.0.0.1", "127.0.0.1", 8080));
    EXPECT_TRUE(hostAllowed("127.0.0.1:8080", "127.0.0.1", 8080));
    EXPECT_TRUE(hostAllowed("LocalHost:8080", "127.0.0.1", 8080));
    EXPECT_TRUE(hostAllowed("[::1]:8080", "::1", 8080));
    EXPECT_FALSE(hostAllowed("127.0.0.1:8081", "127.0.0.1", 8080));
    EXPECT_FALSE(hostAllowed("rebind.example:8080", "127.0.0.1", 8080));
    EXPECT_FALSE(hostAllowed("127.0.0.1:80x", "127.0.0.1", 8080));
    EXPECT_FALSE(hostAllowed("[::1", "::1", 8080));
    // --listen 0.0.0.0: other machines use this one's name; the port must still match.
    EXPECT_TRUE(hostAllowed("nebula-host:8080", "0.0.0.0", 8080));
    EXPECT_FALSE(hostAllowed("nebula-host:9090", "0.0.0.0", 8080));
    EXPECT_TRUE(originAllowed("", "127.0.0.1", 8080));
    EXPECT_TRUE(originAllowed("http://127.0.0.1:8080", "127.0.0.1", 8080));
    EXPECT_FALSE(originAllowed("http://127.0.0.1", "127.0.0.1", 8080));
    EXPECT_FALSE(originAllowed("http://127.0.0.1:8080/", "127.0.0.1", 8080));
    EXPECT_FALSE(originAllowed("null", "127.0.0.1", 8080));
    EXPECT_FALSE(originAllowed("http://[::1]", "::1", 8080));
}

TEST(ViewServer, RefinesToNebrendersImage)
{
    const ViewSettings settings = test::cubeSettings(64, 48);
    Served s(settings);
    Client c(s.server->port(), s.server->token());
    const json hello = c.until("hello");
    EXPECT_EQ(hello["width"], 64);
    EXPECT_EQ(hello["interactive"]["width"], 32);
    ASSERT_EQ(hello["stars"].size(), 1u);
    EXPECT_EQ(hello["stars"][0]["name"], "s");
    EXPECT_EQ(hello["field"], false);
    // The registered camera models, with what the page's controls need.
    ASSERT_EQ(hello["cameras"].size(), cameraModels().size());
    for (std::size_t i = 0; i < cameraModels().size(); ++i) {
        EXPECT_EQ(hello["cameras"][i]["name"], cameraModels()[i]->name());
        EXPECT_EQ(hello["cameras"][i]["fov_max"], cameraModels()[i]->maxFov());
    }
    EXPECT_NEAR(hello["box"]["min"][0].get<double>(), -0.8, 0.11);
    Camera cam = settings.render.camera;
    cam.eye = {0.5, 0.3, -4.0};
    c.send(viewMessage(1, cam, false));
    std::vector<std::string> seen;
    const Frame f = c.frameAt("final", 1, &seen);
    EXPECT_EQ(seen, (std::vector<std::string>{"interactive", "preview", "final"}));
    EXPECT_EQ(f.header["width"], 64);
    EXPECT_EQ(f.header["height"], 48);
    EXPECT_EQ(f.header["format"], "png");
    RenderOptions opts = settings.render; // nebrender's
    opts.camera = cam;
    const Image reference =
        renderFrame(buildScene(*cube(), opts, cube()->dust(nebula::Run())), opts);
    EXPECT_EQ(f.image, pngBytes(reference, computeToneCurve(reference, ToneParams{})));
    // The same camera, another tone: recomposed, not rendered again.
    json v = viewMessage(2, cam, false, "jpeg");
    v["tone"] = {{"auto", true}, {"exposure", 1.0}};
    c.send(v);
    seen.clear();
    const Frame g = c.frameAt("final", 2, &seen);
    EXPECT_EQ(seen, std::vector<std::string>{"final"});
    EXPECT_EQ(g.image.substr(0, 3), std::string("\xff\xd8\xff", 3)); // a JPEG
    EXPECT_NEAR(g.header["white"].get<double>(), f.header["white"].get<double>() / 2, 1e-12);
    // A moving camera gets the interactive frame only.
    cam.eye = {0.6, 0.3, -4.0};
    c.send(viewMessage(3, cam, true));
    const Frame h = c.frameAt("interactive", 3);
    EXPECT_EQ(h.header["width"], 32);
}

TEST(ViewServer, BadMessagesCloseOnlyTheirConnection)
{
    Served s(test::cubeSettings());
    const auto port = s.server->port();
    const std::string t = s.server->token();
    {
        Client c(port, t);
        c.until("hello");
        c.send(json("not an object"));
        EXPECT_FALSE(c.next(nullptr, nullptr));
        EXPECT_EQ(c.ws.reason().code, websocket::close_code::bad_payload);
    }
    {
        Client c(port, t);
        c.until("hello");
        c.ws.text(true);
        c.ws.write(net::buffer(std::string("{\"type\": \"view\", ")));
        EXPECT_FALSE(c.next(nullptr, nullptr));
        EXPECT_EQ(c.ws.reason().code, websocket::close_code::bad_payload);
    }
    {
        Client c(port, t);
        c.until("hello");
        c.ws.text(true);
        c.ws.write(net::buffer(std::string(MAX_CLIENT_MESSAGE + 1, ' ')));
        EXPECT_FALSE(c.next(nullptr, nullptr));
        EXPECT_EQ(c.ws.reason().code, websocket::close_code::too_big);
    }
    {
        Client c(port, t);
        c.until("hello");
        c.ws.binary(true);
        c.ws.write(net::buffer(std::string("\x01\x02", 2)));
        EXPECT_FALSE(c.next(nullptr, nullptr));
    }
    // A known message with a bad value is answered; the session goes on.
    Client c(port, t);
    c.until("hello");
    json v = viewMessage(1, test::cubeSettings().render.camera, false);
    v["camera"]["fov_deg"] = -5;
    c.send(v);
    const json e = c.until("error");
    EXPECT_TRUE(test::contains(e["message"], "fov")) << e.dump();
    c.send(viewMessage(2, test::cubeSettings().render.camera, true));
    EXPECT_EQ(c.frameAt("interactive", 2).header["width"], 32);
}

TEST(ViewServer, AClientThatStopsReadingDoesNotBlockAnother)
{
    Served s(test::cubeSettings(320, 240));
    const auto port = s.server->port();
    const std::string t = s.server->token();
    Client slow(port, t, 4096); // reads nothing after the hello
    slow.until("hello");
    Camera cam = test::cubeSettings(320, 240).render.camera;
    for (int i = 1; i <= 30; ++i) {
        cam.eye.x = 0.01 * i;
        slow.send(viewMessage(i, cam, i % 2 == 0));
    }
    Client fast(port, t);
    fast.until("hello");
    cam.eye.x = -0.2;
    const auto start = std::chrono::steady_clock::now();
    fast.send(viewMessage(7, cam, false));
    const Frame f = fast.frameAt("final", 7);
    EXPECT_EQ(f.header["width"], 320);
    const double seconds =
        std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count();
    EXPECT_LT(seconds, 60.0); // served, not stuck behind the client that does not read
}

TEST(ViewServer, TwoClientsAtOnce)
{
    Served s(test::cubeSettings());
    Client a(s.server->port(), s.server->token()), b(s.server->port(), s.server->token());
    a.until("hello");
    b.until("hello");
    Camera ca = test::cubeSettings().render.camera, cb = ca;
    cb.eye = {1.0, 0.0, -4.0};
    a.send(viewMessage(5, ca, false));
    b.send(viewMessage(9, cb, false));
    const Frame fa = a.frameAt("final", 5), fb = b.frameAt("final", 9);
    EXPECT_NE(fa.image, fb.image);
    EXPECT_EQ(fa.header["camera"]["eye"][0], 0.0);
    EXPECT_EQ(fb.header["camera"]["eye"][0], 1.0);
}

TEST(ViewServer, ProbeAndPaths)
{
    const std::string dir = ::testing::TempDir() + "view_server_paths";
    std::filesystem::create_directories(dir);
    const std::string out = dir + "/path.json";
    std::filesystem::remove(out);
    Served s(test::cubeSettings(64, 48), out);
    Client c(s.server->port(), s.server->token());
    EXPECT_EQ(c.until("hello")["path_out"], out);
    c.send({{"type", "probe"}, {"x", 32}, {"y", 24}});
    EXPECT_TRUE(test::contains(c.until("error")["message"], "no view yet"));
    const Camera cam = test::cubeSettings(64, 48).render.camera;
    c.send(viewMessage(1, cam, true));
    c.send({{"type", "probe"}, {"x", 32}, {"y", 24}});
    const json p = c.until("probe");
    EXPECT_EQ(p["hit"], true);
    EXPECT_NEAR(p["density"].get<double>(), test::VIEW_N0, 1e-3);
    EXPECT_NEAR(p["tau"]["s"].get<double>(), s.session.probe(cam, 32, 24).tau[0], 1e-12);
    c.send({{"type", "probe"}, {"x", 640}, {"y", 24}});
    EXPECT_TRUE(test::contains(c.until("error")["message"], "outside"));

    const json path = {{"fps", 24},
                       {"keyframes",
                        {{{"time", 0}, {"eye", {0, 0, -5}}, {"look_at", {0, 0, 0}}},
                         {{"time", 2}, {"eye", {1, 0, -4}}, {"look_at", {0, 0, 0}}}}}};
    c.send({{"type", "scrub"}, {"path", path}, {"time", 1.0}, {"id", 4}});
    const json cj = c.until("camera");
    const CameraPath parsed = parseCameraPath(path.dump(), "p", cam);
    EXPECT_EQ(cj["camera"]["eye"][0], parsed.at(1.0, cam).eye.x);
    c.frameAt("interactive", 4);
    // The previewed camera, refined, is nebrender's frame of the path at that time (frame
    // 25 at 24 fps is t = 1 s): the same PNG.
    json still = viewMessage(5, cameraFromJson(cj["camera"], cam, "test"), false);
    c.send(still);
    const Frame atOne = c.frameAt("final", 5);
    RenderOptions opts = test::cubeSettings(64, 48).render;
    opts.camera = parsed.at(parsed.frameTime(25), opts.camera);
    const Image nebrender =
        renderFrame(buildScene(*cube(), opts, cube()->dust(nebula::Run())), opts);
    EXPECT_EQ(atOne.image, pngBytes(nebrender, computeToneCurve(nebrender, ToneParams{})));
    c.send({{"type", "save_path"}, {"path", path}});
    const json saved = c.until("saved");
    EXPECT_EQ(saved["keyframes"], 2);
    EXPECT_EQ(saved["frames"], 49); // 2 s at 24 fps, both ends
    EXPECT_TRUE(test::contains(saved["render"], "FLY_FRAMES=49 FLY_FPS=24")) << saved.dump();
    std::ifstream in(out);
    const std::string text((std::istreambuf_iterator<char>(in)), std::istreambuf_iterator<char>());
    EXPECT_EQ(parseCameraPath(text, out, cam).keys.size(), 2u);
    // A path that does not parse: answered with its error, the session goes on.
    c.send(
        {{"type", "load_path"}, {"text", "{\"fps\": 24, \"keyframes\": ["}, {"name", "bad.json"}});
    const json e = c.until("error");
    EXPECT_TRUE(test::contains(e["message"], "bad.json")) << e.dump();
    c.send({{"type", "load_path"}, {"text", text}, {"name", "good.json"}});
    EXPECT_EQ(c.until("path")["path"]["keyframes"].size(), 2u);
    json unordered = path;
    unordered["keyframes"][1]["time"] = 0;
    c.send({{"type", "save_path"}, {"path", unordered}});
    EXPECT_TRUE(test::contains(c.until("error")["message"], "time"));
}

TEST(ViewProtocol, MessagesAreCheckedBeforeUse)
{
    const std::vector<std::string> stars{"a", "b"};
    const Camera base;
    const auto parse = [&](const std::string& text) {
        return parseClientMessage(text, stars, base, "p.json");
    };
    EXPECT_THROW(parse("[]"), MalformedMessage);
    EXPECT_THROW(parse("{}"), MalformedMessage);
    EXPECT_THROW(parse("{\"type\": \"shutdown\"}"), MalformedMessage);
    EXPECT_THROW(parse("{\"type\": 3}"), MalformedMessage);
    EXPECT_THROW(parse(std::string(MAX_CLIENT_MESSAGE + 1, ' ')), MalformedMessage);
    EXPECT_THROW(parse(std::string(200, '[')), MalformedMessage);
    const std::string cam = R"("camera": {"eye": [0, 0, -5], "look_at": [0, 0, 0]})";
    const ClientMessage m = parse(R"({"type": "view", "id": 3, )" + cam +
                                  R"(, "show": {"stars": {"b": false}}, "mode": "spectral"})");
    EXPECT_EQ(m.view.id, 3);
    EXPECT_EQ(m.view.show.stars, (std::vector<bool>{true, false}));
    EXPECT_TRUE(m.view.spectral);
    EXPECT_EQ(m.view.camera.eye.z, -5.0);
    for (const std::string& bad : std::vector<std::string>{
             R"({"type": "view", "id": -1, )" + cam + "}",
             R"({"type": "view", "id": 1.5, )" + cam + "}",
             R"({"type": "view", "id": 1, "camera": {"eye": [0, 0]}})",
             R"({"type": "view", "id": 1, "camera": {"eye": [0, 0, "x"]}})",
             R"({"type": "view", "id": 1, "camera": {"eye": [0, 0, 0], "look_at": [0, 0, 0]}})",
             R"({"type": "view", "id": 1, "camera": {"projection": "ods"}})",
             R"({"type": "view", "id": 1, )" + cam + R"(, "tone": {"gamma": 0}})",
             R"({"type": "view", "id": 1, )" + cam + R"(, "format": "gif"})",
             R"({"type": "probe", "x": 1})", R"({"type": "scrub", "time": 1, "path": 3})",
             R"({"type": "load_path"})"}) {
        EXPECT_THROW(parse(bad), Error) << bad;
    }
}
