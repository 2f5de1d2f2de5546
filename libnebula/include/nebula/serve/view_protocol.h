// SPDX-License-Identifier: Apache-2.0
#pragma once
/// @file view_protocol.h
/// nebview's messages (docs/tools/nebview-protocol.md): what the page sends, parsed and
/// checked; cameras and paths as JSON. Every message from the network passes
/// parseClientMessage() before anything acts on it (the fuzzer's target).

#include "nebula/core/error.h"
#include "nebula/io/image.h"
#include "nebula/render/camera_path.h"
#include "nebula/stages/view.h"

#include <nlohmann/json.hpp>

#include <cstddef>
#include <cstdint>
#include <optional>
#include <string>
#include <vector>

namespace nebula {

/// The largest message the page may send [bytes]; a larger one closes its connection.
inline constexpr std::size_t MAX_CLIENT_MESSAGE = 64 * 1024;

/// A message that is not one of the protocol's (not a JSON object, no known "type"): its
/// connection is closed. A known message with a bad value throws Error (answered with an
/// "error" message; the session goes on).
class MalformedMessage : public Error
{
public:
    explicit MalformedMessage(const std::string& what) : Error(what) {}
};

/// Whether a request's Host header @p host ("NAME" or "NAME:PORT") names this server, which
/// listens on @p address (an IP address) and @p port: the port, where given, is @p port;
/// a server on a loopback address answers only to its own names (127.0.0.1, localhost,
/// [::1]), so that a web page whose own name resolves to 127.0.0.1 (DNS rebinding) is refused;
/// one listening on another address (--listen) answers to any name.
bool hostAllowed(const std::string& host, const std::string& address, std::uint16_t port);

/// Whether a WebSocket upgrade's Origin header @p origin is this server's own page:
/// "http://NAME:PORT" with hostAllowed(NAME:PORT) and the port given. An empty @p origin (a
/// client that is not a browser: browsers always send one) is allowed; "null" and any other
/// site are not (cross-site WebSocket hijacking).
bool originAllowed(const std::string& origin, const std::string& address, std::uint16_t port);

/// The page's tone: the automatic curve (DESIGN §8) shifted by `exposure` stops, or a fixed
/// white point 2^-exposure; gamma fitted (none) or fixed.
struct ToneRequest
{
    bool automatic = true;
    double exposure = 0.0; ///< [stops]
    std::optional<double> gamma;
};

/// A "view" message.
struct ViewRequest
{
    long long id = 0;
    Camera camera; ///< the view (its size is the stage's)
    bool moving = false;
    bool spectral = false;
    bool png = false;
    ToneRequest tone;
    ViewShow show;
};

struct ClientMessage
{
    enum class Kind { View, Probe, Scrub, LoadPath, SavePath };
    Kind kind = Kind::View;
    ViewRequest view;       ///< View
    double x = 0, y = 0;    ///< Probe: the full-resolution pixel
    double time = 0;        ///< Scrub
    CameraPath path;        ///< Scrub, SavePath (parsed and checked)
    std::string text, name; ///< LoadPath: the file's text and name
};

/// Parses one message of the page. @p stars: the scene's star names (a view's "show.stars");
/// @p base: the camera the unspecified parts come from (size, model defaults); @p pathName:
/// the name a path's errors carry. Throws MalformedMessage or Error (see above).
ClientMessage parseClientMessage(const std::string& text, const std::vector<std::string>& stars,
                                 const Camera& base, const std::string& pathName);

/// A camera as the protocol's JSON: the one camera JSON (cameraToJson(),
/// render/camera_model.h).
nlohmann::json cameraJson(const Camera& camera);
/// The protocol's camera over @p base (nebula::cameraFromJson()), valid (a Projection is
/// made of it); throws Error naming @p where on a bad value.
Camera viewCameraFromJson(const nlohmann::json& j, const Camera& base, const std::string& where);
/// A path's JSON (cameraPathJson() as an object).
nlohmann::json pathJson(const CameraPath& path);

/// The tone curve of a composed frame: the automatic curve of @p image (percentile, fixed
/// gamma from @p base) with the request's exposure and gamma, or the fixed curve.
ToneCurve requestTone(const Image& image, const ToneRequest& request, const ToneParams& base);

} // namespace nebula
