// SPDX-License-Identifier: Apache-2.0
#include "nebula/serve/view_protocol.h"

#include "nebula/core/format.h"
#include "nebula/render/camera_model.h"

#include <fmt/format.h>

#include <algorithm>
#include <cctype>
#include <cmath>

namespace nebula {

namespace {

using nlohmann::json;

double number(const json& j, const char* key, const std::string& where)
{
    const auto it = j.find(key);
    if (it == j.end() || !it->is_number()) {
        throw Error(where + ": \"" + key + "\" must be a number");
    }
    const double v = it->get<double>();
    if (!std::isfinite(v)) throw Error(where + ": \"" + key + "\" must be finite");
    return v;
}

bool flag(const json& j, const char* key, bool fallback, const std::string& where)
{
    const auto it = j.find(key);
    if (it == j.end()) return fallback;
    if (!it->is_boolean()) throw Error(where + ": \"" + key + "\" must be true or false");
    return it->get<bool>();
}

const json& object(const json& j, const char* key, const std::string& where)
{
    const auto it = j.find(key);
    if (it == j.end() || !it->is_object()) {
        throw Error(where + ": \"" + key + "\" must be an object");
    }
    return *it;
}

CameraPath pathFromJson(const json& j, const Camera& base, const std::string& name)
{
    if (!j.is_object()) throw Error(name + ": a camera path must be a JSON object");
    return parseCameraPath(j.dump(), name, base);
}

} // namespace

json cameraJson(const Camera& c)
{
    return cameraToJson(c);
}

Camera viewCameraFromJson(const json& j, const Camera& base, const std::string& where)
{
    Camera c = cameraFromJson(j, base, where);
    // The page switches models: the base's parameters that the new model does not read go.
    const CameraModel& model = cameraModel(c.model);
    for (const CameraParameter& p : cameraParameters()) {
        if (!model.reads(p.name) && !j.contains(p.json)) p.set(c, {});
    }
    try {
        (void)Projection(c); // a created camera is valid
    } catch (const Error& e) {
        throw Error(where + ": " + e.what());
    }
    return c;
}

json pathJson(const CameraPath& path)
{
    return json::parse(cameraPathJson(path));
}

bool hostAllowed(const std::string& host, const std::string& address, std::uint16_t port)
{
    if (host.empty() || host.size() > 255) return false;
    // NAME, NAME:PORT, [V6], [V6]:PORT
    std::string name = host, portText;
    if (host.front() == '[') {
        const auto close = host.find(']');
        if (close == std::string::npos) return false;
        name = host.substr(0, close + 1);
        const std::string rest = host.substr(close + 1);
        if (!rest.empty()) {
            if (rest[0] != ':') return false;
            portText = rest.substr(1);
        }
    } else if (const auto colon = host.rfind(':'); colon != std::string::npos) {
        name = host.substr(0, colon);
        portText = host.substr(colon + 1);
    }
    if (host.find(':') != std::string::npos && host.front() != '[' && portText.empty())
        return false; // "NAME:"
    if (!portText.empty()) {
        if (portText.size() > 5 || portText.find_first_not_of("0123456789") != std::string::npos)
            return false;
        if (std::stoul(portText) != port) return false;
    }
    if (name.empty()) return false;
    std::string lower;
    for (const char c : name)
        lower += char(std::tolower(static_cast<unsigned char>(c)));
    const bool loopback = address == "127.0.0.1" || address == "::1" || address == "localhost";
    if (!loopback) return true;
    return lower == "127.0.0.1" || lower == "localhost" || lower == "[::1]";
}

bool originAllowed(const std::string& origin, const std::string& address, std::uint16_t port)
{
    if (origin.empty()) return true;
    const std::string scheme = "http://";
    if (origin.compare(0, scheme.size(), scheme) != 0) return false;
    const std::string host = origin.substr(scheme.size());
    // The port must be given: the page is served from it, never from port 80.
    if (host.empty() || host.back() == ']' || host.find(':') == std::string::npos) return false;
    if (host.find('/') != std::string::npos) return false;
    return hostAllowed(host, address, port);
}

ClientMessage parseClientMessage(const std::string& text, const std::vector<std::string>& stars,
                                 const Camera& base, const std::string& pathName)
{
    if (text.size() > MAX_CLIENT_MESSAGE) {
        throw MalformedMessage(
            fmt::format("a message of {} bytes, more than {}", text.size(), MAX_CLIENT_MESSAGE));
    }
    json j;
    try {
        j = detail::parseJson(text, "message");
    } catch (const Error& e) {
        throw MalformedMessage(e.what());
    }
    if (!j.is_object() || !j.contains("type") || !j["type"].is_string()) {
        throw MalformedMessage("a message must be a JSON object with a \"type\"");
    }
    const std::string type = j["type"].get<std::string>();
    ClientMessage m;
    const std::string where = type;
    if (type == "view") {
        m.kind = ClientMessage::Kind::View;
        ViewRequest& v = m.view;
        const double id = number(j, "id", where);
        if (id < 0 || id > 9e15 || id != std::floor(id)) {
            throw Error(where + ": \"id\" must be a whole number >= 0");
        }
        v.id = static_cast<long long>(id);
        v.camera = viewCameraFromJson(object(j, "camera", where), base, where + ": camera");
        v.moving = flag(j, "moving", false, where);
        if (j.contains("mode")) {
            const json& mode = j["mode"];
            if (mode != "rgb" && mode != "spectral") {
                throw Error(where + ": \"mode\" must be \"rgb\" or \"spectral\"");
            }
            v.spectral = mode == "spectral";
        }
        if (j.contains("format")) {
            const json& format = j["format"];
            if (format != "jpeg" && format != "png") {
                throw Error(where + ": \"format\" must be \"jpeg\" or \"png\"");
            }
            v.png = format == "png";
        }
        if (j.contains("tone")) {
            const json& t = object(j, "tone", where);
            const std::string tw = where + ": tone";
            v.tone.automatic = flag(t, "auto", true, tw);
            if (t.contains("exposure")) v.tone.exposure = number(t, "exposure", tw);
            if (std::abs(v.tone.exposure) > 1000) {
                throw Error(tw + ": \"exposure\" must be within +-1000 stops");
            }
            if (t.contains("gamma") && !t["gamma"].is_null()) {
                const double g = number(t, "gamma", tw);
                if (!(g > 0.0 && g <= 10.0)) throw Error(tw + ": \"gamma\" must be in (0, 10]");
                v.tone.gamma = g;
            }
        }
        if (j.contains("show")) {
            const json& s = object(j, "show", where);
            const std::string sw = where + ": show";
            v.show.single = flag(s, "single", true, sw);
            v.show.field = flag(s, "field", true, sw);
            v.show.emission = flag(s, "emission", true, sw);
            v.show.sprites = flag(s, "sprites", true, sw);
            if (s.contains("stars")) {
                const json& on = object(s, "stars", sw);
                v.show.stars.assign(stars.size(), true);
                for (std::size_t i = 0; i < stars.size(); ++i)
                    v.show.stars[i] = flag(on, stars[i].c_str(), true, sw + ": stars");
            }
        }
    } else if (type == "probe") {
        m.kind = ClientMessage::Kind::Probe;
        m.x = number(j, "x", where);
        m.y = number(j, "y", where);
    } else if (type == "scrub") {
        m.kind = ClientMessage::Kind::Scrub;
        m.time = number(j, "time", where);
        if (j.contains("id")) { // the frame's id (the page's flow control)
            const double id = number(j, "id", where);
            if (id >= 0 && id <= 9e15) m.view.id = static_cast<long long>(id);
        }
        if (!j.contains("path")) throw Error(where + ": \"path\" is missing");
        m.path = pathFromJson(j["path"], base, pathName);
    } else if (type == "load_path") {
        m.kind = ClientMessage::Kind::LoadPath;
        if (!j.contains("text") || !j["text"].is_string()) {
            throw Error(where + ": \"text\" must be a string");
        }
        m.text = j["text"].get<std::string>();
        if (j.contains("name") && j["name"].is_string()) {
            m.name = j["name"].get<std::string>().substr(0, 200);
        }
    } else if (type == "save_path") {
        m.kind = ClientMessage::Kind::SavePath;
        if (!j.contains("path")) throw Error(where + ": \"path\" is missing");
        m.path = pathFromJson(j["path"], base, pathName);
    } else {
        throw MalformedMessage("unknown message type \"" + type.substr(0, 40) + "\"");
    }
    return m;
}

ToneCurve requestTone(const Image& image, const ToneRequest& request, const ToneParams& base)
{
    ToneParams p = base;
    if (request.automatic) {
        p.automatic = true;
        if (request.gamma) {
            p.fixedGamma = true;
            p.gamma = *request.gamma;
        }
        ToneCurve curve = computeToneCurve(image, p);
        curve.white *= std::exp2(-request.exposure);
        return curve;
    }
    p.automatic = false;
    p.exposure = request.exposure;
    p.gamma = request.gamma.value_or(1.0);
    return computeToneCurve(image, p);
}

} // namespace nebula
