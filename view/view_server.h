// The live view's server: HTTP + WebSocket on one port (Boost.Beast), on a thread of its own.
//
// It serves the page (view/web, with three.js from view/web/node_modules: no CDN), the display basis
// once (GET /api/basis, binary, see view/README.md), a JSON description of the basis and the report
// beside it (/api/info, /api/report), with --compare the felt-stiffness maps of two designs compared
// (/api/comparison), the latest state (/api/state), and pushes each frame a
// FrameSource builds to every WebSocket client (/ws) as soon as the source publishes it. Text messages from a client are
// commands for the FrameSource (the mouse as a device). Nothing here runs in the haptic thread.
// Every request passes the AccessGuard first (access_guard.h: Host, origin, this run's token).
#pragma once

#include <modalrt/modalrt.h>

#include <cstdint>
#include <memory>
#include <string>
#include <vector>

namespace modalrt_view
{
  // What the page shows: the view command's mouse session, or a run/serve loop.
  class FrameSource
  {
  public:
    virtual ~FrameSource() = default;
    // Server thread, after each ViewServer::publish: the newest frame's bytes (view/README.md,
    // "Frame"). Returns false when there is nothing to send.
    virtual bool frame(std::vector<unsigned char> &bytes) = 0;
    // Server thread: a text command from a browser ("press HIP VERTEX FORCE", "release HIP"); returns
    // a reply for that browser ("" for none).
    virtual std::string command(const std::string &text) = 0;
    // Server thread: the latest state as JSON (GET /api/state).
    virtual std::string state_json() = 0;
    // Once, before the server starts: what drives the HIPs, as the JSON object "session" of
    // GET /api/info: {"driver": "mouse"|"run"|"serve", "watch_only": bool, "hips": N}. A watch-only
    // page does not press (the HIPs belong to a script or a device).
    virtual std::string session_json() = 0;
  };

  struct ServerOptions
  {
    std::string address    = "127.0.0.1"; // loopback unless asked otherwise
    unsigned    port       = 8080;        // 0: any free port
    std::string web_root;                 // folder of index.html (default: the source tree's view/web)
    std::string compare_basis;            // design B's .mrt: the Stiffness tab's difference map (empty: none)
    double      noise_percent = 1.0;      // its noise floor [%]: |B - A| / A at or below it, no difference
  };

  // Default web root: MODAL_RT_VIEW_WEB if set, else the source tree's view/web.
  std::string default_web_root();

  class ViewServer
  {
  public:
    // The basis must outlive the server; `basis_path` locates report.json beside it. Throws
    // std::runtime_error naming the file when options.compare_basis cannot be compared.
    ViewServer(const modalrt_basis *basis, const std::string &basis_path, FrameSource &source, ServerOptions options);
    ~ViewServer();
    ViewServer(const ViewServer &) = delete;
    ViewServer &operator=(const ViewServer &) = delete;

    // Binds and starts the server thread; throws std::runtime_error naming the address and port.
    void     start();
    void     stop();
    unsigned port() const;
    // After start(): the page's address with this run's token, http://ADDRESS:PORT/?token=HEX (the
    // token, 256 random bits, is new each run; /ws and /api/* refuse a request without it).
    std::string url() const;
    // Any thread: the source has a new frame; the server thread sends it to every browser.
    void publish();
    // Bytes of GET /api/basis (sent once per browser).
    std::size_t basis_bytes() const;

    struct Impl; // view_server.cc

  private:
    std::unique_ptr<Impl> impl_;
  };

  // --- shared helpers of the frame sources --------------------------------------------------------
  double wall_clock_ms(); // [ms] since the Unix epoch (the browser's Date.now() clock)
} // namespace modalrt_view
