// SPDX-License-Identifier: Apache-2.0
#pragma once
/// @file view_server.h
/// nebview's server: HTTP and WebSocket (Boost.Beast) on one I/O thread, a render thread
/// that renders the newest view of each client at three stages, cancelling a frame in flight
/// when a newer view arrives, and frames as JPEG (libturbojpeg) or PNG. The page is the one
/// embedded in the binary (libnebula/data/nebview/index.html); every request carries the
/// access token; the only file written is the camera path (--path-out).

#include "nebula/core/run.h"
#include "nebula/render/camera_path.h"
#include "nebula/stages/view.h"

#include <cstdint>
#include <memory>
#include <string>
#include <vector>

namespace nebula {

struct ViewServerOptions
{
    std::string address = "127.0.0.1";      ///< where to listen (--listen)
    std::uint16_t port = 0;                 ///< 0: a free port
    std::string token;                      ///< empty: 32 random hex digits
    std::string pathOut;                    ///< where Save writes the camera path ("": nowhere)
    std::shared_ptr<const CameraPath> path; ///< the path the page starts with
    int jpegQuality = 85;
    int maxClients = 8; ///< WebSocket sessions at once; more are answered 503
};

/// JPEG of RGBA pixels (displayPixels()), 4:2:0, at @p quality (1-100). Throws Error.
std::string jpegBytes(const std::vector<std::uint8_t>& rgba, int width, int height, int quality);

/// The embedded page.
const std::string& viewerPage();

class ViewServer
{
public:
    /// Binds (throws Error naming the address and port if it cannot: in use, not an address
    /// of this machine) and starts the render thread; serves once run() is called.
    ViewServer(const ViewSession& session, const ViewServerOptions& options, const Run& run);
    ~ViewServer();
    ViewServer(const ViewServer&) = delete;
    ViewServer& operator=(const ViewServer&) = delete;

    /// The port bound, and the page's URL with the token.
    std::uint16_t port() const;
    std::string url() const;
    const std::string& token() const;

    /// Serves until stop() (from any thread).
    void run();
    void stop();

    struct Impl;

private:
    std::unique_ptr<Impl> mImpl;
};

} // namespace nebula
