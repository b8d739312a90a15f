#include "view_server.h"

#include "access_guard.h"
#include "view_json.h"
#include "design_comparison.h" // realtime/tools
#include "stiffness_map.h"     // realtime/tools

#include <boost/asio/ip/tcp.hpp>
#include <boost/asio/post.hpp>
#include <boost/beast/core.hpp>
#include <boost/beast/http.hpp>
#include <boost/beast/websocket.hpp>

#include <chrono>
#include <cmath>
#include <cstdio>
#include <cstring>
#include <deque>
#include <filesystem>
#include <fstream>
#include <list>
#include <sstream>
#include <stdexcept>
#include <thread>

#ifndef MODAL_RT_VIEW_WEB_DIR
#  define MODAL_RT_VIEW_WEB_DIR "view/web"
#endif

namespace modalrt_view
{
  namespace beast     = boost::beast;
  namespace http      = boost::beast::http;
  namespace websocket = boost::beast::websocket;
  namespace asio      = boost::asio;
  using tcp           = boost::asio::ip::tcp;

  double wall_clock_ms()
  {
    return std::chrono::duration<double, std::milli>(std::chrono::system_clock::now().time_since_epoch()).count();
  }

  std::string default_web_root()
  {
    if (const char *root = std::getenv("MODAL_RT_VIEW_WEB"))
      return root;
    return MODAL_RT_VIEW_WEB_DIR;
  }

  namespace
  {
    template <typename T>
    void append(std::vector<unsigned char> &bytes, const T *values, std::size_t count)
    {
      const auto *p = reinterpret_cast<const unsigned char *>(values);
      bytes.insert(bytes.end(), p, p + count * sizeof(T));
    }

    void append_u32(std::vector<unsigned char> &bytes, std::uint32_t value) { append(bytes, &value, 1); }

    std::string read_file(const std::filesystem::path &path, bool &ok)
    {
      std::ifstream in(path, std::ios::binary);
      ok = bool(in);
      if (!ok)
        return {};
      std::ostringstream s;
      s << in.rdbuf();
      return s.str();
    }

    // Space s's display modes (r per vertex), read from the file at the offset its section table
    // gives (docs/basis-format.md: entry (v, c, i) at (3 v + c) r + i), as float64.
    std::vector<double> read_display_modes(const modalrt_basis *basis, const modalrt_basis_info &info,
                                           const std::string &path, std::ifstream &in, std::uint32_t s,
                                           std::uint32_t r)
    {
      modalrt_section_info section{};
      bool                 found = false;
      for (std::uint32_t k = 0; k < info.section_count && !found; ++k)
        if (modalrt_basis_get_section(basis, k, &section) == MODALRT_OK &&
            std::strcmp(section.name, "DISPLAY_MODES") == 0 && section.space == s)
          found = true;
      if (!found || section.count != 3 * std::uint64_t(info.display_vertex_count) * r)
        throw std::runtime_error(path + ": no DISPLAY_MODES section of the expected size for space " +
                                 std::to_string(s));
      std::vector<double> modes(section.count);
      in.seekg(std::streamoff(section.offset));
      if (info.mode_scalar_bytes == 8)
        in.read(reinterpret_cast<char *>(modes.data()), std::streamsize(section.bytes));
      else
        {
          std::vector<float> m32(section.count);
          in.read(reinterpret_cast<char *>(m32.data()), std::streamsize(section.bytes));
          for (std::size_t i = 0; i < m32.size(); ++i)
            modes[i] = m32[i];
        }
      if (!in)
        throw std::runtime_error(path + ": cannot read the display modes of space " + std::to_string(s));
      return modes;
    }

    // The display basis in the view's binary layout (view/README.md, "Basis"): rest vertices,
    // triangles, normals and regions, then per space its display modes as float32, per vertex and
    // mode one (x, y, z) triple (the layout of the shader's texture), plus, when the file stores
    // float64 modes, the same in float64 (the page's exact read-out of a vertex); last the scene's
    // felt-stiffness map.
    std::vector<unsigned char> basis_binary(const modalrt_basis *basis, const std::string &path)
    {
      modalrt_basis_info info{};
      modalrt_basis_get_info(basis, &info);
      const std::uint32_t nv = info.display_vertex_count, nt = info.display_triangle_count;
      std::vector<unsigned char> bytes;
      bytes.reserve(64 + std::size_t(nv) * 40 + std::size_t(nt) * 12);
      const char magic[8] = {'M', 'R', 'T', 'V', 'I', 'E', 'W', '1'};
      append(bytes, magic, 8);
      append_u32(bytes, nv);
      append_u32(bytes, nt);
      append_u32(bytes, info.space_count);
      append_u32(bytes, info.mode_scalar_bytes);
      std::vector<float> f(3 * std::size_t(nv));
      const double      *x = modalrt_basis_display_vertices(basis);
      for (std::size_t i = 0; i < f.size(); ++i)
        f[i] = float(x[i]);
      append(bytes, f.data(), f.size());
      append(bytes, modalrt_basis_display_triangles(basis), 3 * std::size_t(nt));
      const double *n = modalrt_basis_display_normals(basis);
      for (std::size_t i = 0; i < f.size(); ++i)
        f[i] = float(n[i]);
      append(bytes, f.data(), f.size());
      append(bytes, modalrt_basis_display_regions(basis), nv);

      std::ifstream in(path, std::ios::binary);
      if (!in)
        throw std::runtime_error(path + ": cannot be opened to read its display modes");
      for (std::uint32_t s = 0; s < info.space_count; ++s)
        {
          modalrt_space_info space{};
          modalrt_basis_get_space_info(basis, s, &space);
          const std::uint32_t       r     = space.mode_count;
          const std::vector<double> modes = read_display_modes(basis, info, path, in, s, r);
          append_u32(bytes, r);
          append_u32(bytes, 0);
          // Shader layout: texel (v r + i) holds (Phi_x, Phi_y, Phi_z) of mode i at vertex v.
          std::vector<float>  shader(3 * std::size_t(nv) * r);
          std::vector<double> exact(info.mode_scalar_bytes == 8 ? shader.size() : 0);
          for (std::uint32_t v = 0; v < nv; ++v)
            for (std::uint32_t i = 0; i < r; ++i)
              for (int c = 0; c < 3; ++c)
                {
                  const double value = modes[(3 * std::size_t(v) + c) * r + i];
                  const std::size_t j = (std::size_t(v) * r + i) * 3 + c;
                  shader[j] = float(value);
                  if (!exact.empty())
                    exact[j] = value;
                }
          append(bytes, shader.data(), shader.size());
          if (!exact.empty())
            append(bytes, exact.data(), exact.size());
        }
      // The scene's felt-stiffness map [N/mm]: each vertex from its region's space, 0 where it was
      // not computed (and everywhere when the file has no map).
      std::vector<float> stiffness(nv);
      for (std::uint32_t v = 0; v < nv; ++v)
        stiffness[v] = float(1e-3 * modalrt_tool::scene_felt_stiffness(basis, v));
      append(bytes, stiffness.data(), stiffness.size());
      return bytes;
    }

    // A number as the page reads it: a non-finite one as null.
    Json number(double x) { return std::isfinite(x) ? Json(x) : Json(nullptr); }

    Json space_json(const modalrt_basis *basis, std::uint32_t s, std::uint32_t &case_index)
    {
      modalrt_space_info space{};
      modalrt_basis_get_space_info(basis, s, &space);
      const double   *lambda     = modalrt_basis_eigenvalues(basis, s);
      const uint32_t *candidates = modalrt_basis_candidates(basis, s);
      Json            j;
      j["name"]  = space.name;
      j["modes"] = space.mode_count;
      j["cross"] = space.cross_count > 0;
      Json &frequencies = j["frequencies_hz"] = Json::array();
      for (std::uint32_t i = 0; i < space.mode_count; ++i)
        frequencies.push_back(number(std::sqrt(std::max(0.0, lambda[i])) / (2.0 * M_PI)));
      j["candidates"] = std::vector<std::uint32_t>(candidates, candidates + space.candidate_count);
      Json &validation = j["validation"] = Json::array();
      for (std::uint32_t c = 0; c < space.validation_count; ++c, ++case_index)
        {
          modalrt_verify_case vc{};
          modalrt_basis_verify_case(basis, case_index, &vc);
          validation.push_back({{"vertex", vc.vertex}, {"direction", vc.direction}, {"kernel_rel_error", number(vc.relative_error)}});
        }
      return j;
    }

    // GET /api/comparison (view/README.md, "Comparison"): design B's scene map read at A's display
    // vertices by mrt::compare_maps, the summary and per vertex the difference in % of A (null where
    // it was not compared) and B's value there [N/mm].
    std::string comparison_json(const modalrt_basis *basis, const std::string &path, const ServerOptions &options)
    {
      modalrt_tool::DesignComparisonOptions settings;
      settings.noise_percent = options.noise_percent;
      mrt::MapComparison c;
      std::string        error;
      if (!modalrt_tool::compare_scene_maps(basis, path.c_str(), options.compare_basis.c_str(), settings, c, error))
        throw std::runtime_error("--compare: " + error);
      Json j;
      j["file"]                 = options.compare_basis;
      j["rule"]                 = mrt::match_rule_name(c.rule);
      j["b_vertices"]           = c.b_vertex_count;
      j["compared"]             = c.compared_count;
      j["a_without_value"]      = c.a_without_value;
      j["b_without_value"]      = c.b_without_value;
      j["match_distance_max_m"] = number(c.max_match_distance);
      j["match_distance_p95_m"] = number(c.p95_match_distance);
      j["ratio"]                = {{"min", c.ratio_min}, {"median", c.ratio_median}, {"max", c.ratio_max}};
      j["noise_floor_percent"]  = c.noise_floor_percent;
      j["beyond_noise"]         = c.beyond_noise_count;
      Json &percent = j["percent"] = Json::array();
      Json &b_value = j["b_n_per_mm"] = Json::array();
      for (std::size_t v = 0; v < c.a_vertex_count; ++v)
        {
          percent.push_back(c.compared[v] ? Json(c.percent[v]) : Json(nullptr));
          b_value.push_back(c.b_at_a[v] > 0.0 ? Json(1e-3 * c.b_at_a[v]) : Json(nullptr));
        }
      return dump_json(j);
    }

    // What the page needs to know about the basis (GET /api/info, view/README.md): counts, spaces
    // (frequencies, candidates, validation cases with the kernel's own self-check error), scene
    // scalars, and `session`, what drives the HIPs.
    std::string info_json(const modalrt_basis *basis, const std::string &path, std::size_t basis_bytes,
                          const std::string &session, const std::string &compare_basis)
    {
      modalrt_basis_info info{};
      modalrt_basis_get_info(basis, &info);
      Json j;
      j["file"]               = path;
      j["vertices"]           = info.display_vertex_count;
      j["triangles"]          = info.display_triangle_count;
      j["mode_scalar_bytes"]  = info.mode_scalar_bytes;
      j["patch_radius_m"]     = number(info.patch_radius);
      j["basis_bytes"]        = basis_bytes;
      j["felt_stiffness_map"] = modalrt_tool::has_felt_stiffness_map(basis);
      j["validity_map"]       = modalrt_tool::has_validity_map(basis);
      j["comparison"]         = compare_basis.empty() ? Json(nullptr) : Json(compare_basis); // GET /api/comparison
      j["bounds_min"] = {number(info.bounds_min[0]), number(info.bounds_min[1]), number(info.bounds_min[2])};
      j["bounds_max"] = {number(info.bounds_max[0]), number(info.bounds_max[1]), number(info.bounds_max[2])};
      Json         &spaces     = j["spaces"] = Json::array();
      std::uint32_t case_index = 0;
      for (std::uint32_t s = 0; s < info.space_count; ++s)
        spaces.push_back(space_json(basis, s, case_index));
      j["session"] = Json::parse(session);
      return dump_json(j);
    }

    // three.js's add-ons import the bare name 'three', which a browser resolves only through an import
    // map, an inline script the page's Content-Security-Policy forbids: served with the module's
    // path instead.
    std::string with_three_resolved(std::string module)
    {
      const std::pair<const char *, const char *> paths[] = {{"from 'three'", "from '/three/build/three.module.js'"},
                                                             {"from 'three/addons/", "from '/three/examples/jsm/"}};
      for (const auto &[bare, path] : paths)
        for (std::size_t at = module.find(bare); at != std::string::npos; at = module.find(bare, at))
          module.replace(at, std::strlen(bare), path);
      return module;
    }

    const char *content_type(const std::string &path)
    {
      const auto ends = [&](const char *suffix) {
        const std::size_t n = std::strlen(suffix);
        return path.size() >= n && path.compare(path.size() - n, n, suffix) == 0;
      };
      if (ends(".html"))
        return "text/html; charset=utf-8";
      if (ends(".js"))
        return "text/javascript; charset=utf-8";
      if (ends(".css"))
        return "text/css";
      if (ends(".json"))
        return "application/json";
      if (ends(".png"))
        return "image/png";
      return "application/octet-stream";
    }
  } // namespace

  // ---------------------------------------------------------------------------------------------
  struct WebSocketSession;

  struct ViewServer::Impl
  {
    const modalrt_basis *basis;
    std::string          basis_path;
    FrameSource         &source;
    ServerOptions        options;
    std::string          info_json;
    std::string          basis_bytes;
    std::string          report;
    bool                 has_report = false;
    std::string          comparison; // GET /api/comparison ("": no --compare)
    std::string          token = random_token();
    std::unique_ptr<AccessGuard> guard; // made once the port is bound

    asio::io_context                      io;
    tcp::acceptor                         acceptor{io};
    std::thread                           thread;
    std::list<std::weak_ptr<WebSocketSession>> sessions;
    std::vector<unsigned char>            frame_bytes;
    unsigned                              bound_port = 0;

    Impl(const modalrt_basis *b, const std::string &p, FrameSource &s, ServerOptions o)
      : basis(b), basis_path(p), source(s), options(std::move(o))
    {}

    void accept();
    void send_frame();
  };

  // One browser on /ws: frames out (at most one waiting: a slow browser skips frames, it never
  // makes the server queue without bound), commands in.
  struct WebSocketSession : std::enable_shared_from_this<WebSocketSession>
  {
    websocket::stream<beast::tcp_stream>           ws;
    ViewServer::Impl                              &server;
    beast::flat_buffer                             input;
    std::deque<std::shared_ptr<const std::string>> replies;
    std::shared_ptr<const std::vector<unsigned char>> pending_frame;
    bool                                           writing = false;
    bool                                           open    = false;

    WebSocketSession(tcp::socket socket, ViewServer::Impl &s) : ws(std::move(socket)), server(s) {}

    void start(http::request<http::string_body> request)
    {
      ws.set_option(websocket::stream_base::timeout::suggested(beast::role_type::server));
      ws.read_message_max(4096); // a command is a line of text
      auto self = shared_from_this();
      ws.async_accept(request, [self](beast::error_code ec) {
        if (ec)
          return;
        self->open = true;
        self->read();
      });
    }

    void read()
    {
      auto self = shared_from_this();
      ws.async_read(input, [self](beast::error_code ec, std::size_t) {
        if (ec)
          {
            self->open = false;
            return;
          }
        const std::string text = beast::buffers_to_string(self->input.data());
        self->input.consume(self->input.size());
        const std::string reply = self->server.source.command(text);
        if (!reply.empty())
          {
            self->replies.push_back(std::make_shared<const std::string>(reply));
            self->write();
          }
        self->read();
      });
    }

    void send_frame(const std::shared_ptr<const std::vector<unsigned char>> &frame)
    {
      if (!open)
        return;
      pending_frame = frame; // replaces an unsent older frame
      write();
    }

    void write()
    {
      if (writing || !open)
        return;
      auto self = shared_from_this();
      if (!replies.empty())
        {
          auto text = replies.front();
          replies.pop_front();
          writing = true;
          ws.text(true);
          ws.async_write(asio::buffer(*text), [self, text](beast::error_code ec, std::size_t) {
            self->writing = false;
            if (ec)
              self->open = false;
            else
              self->write();
          });
        }
      else if (pending_frame)
        {
          auto frame = std::move(pending_frame);
          pending_frame.reset();
          writing = true;
          ws.binary(true);
          ws.async_write(asio::buffer(*frame), [self, frame](beast::error_code ec, std::size_t) {
            self->writing = false;
            if (ec)
              self->open = false;
            else
              self->write();
          });
        }
    }
  };

  // One HTTP connection: files and the API, or an upgrade to a WebSocket on /ws.
  struct HttpSession : std::enable_shared_from_this<HttpSession>
  {
    beast::tcp_stream                 stream;
    ViewServer::Impl                 &server;
    beast::flat_buffer                buffer;
    http::request<http::string_body>  request;

    HttpSession(tcp::socket socket, ViewServer::Impl &s) : stream(std::move(socket)), server(s) {}

    void read()
    {
      request = {};
      stream.expires_after(std::chrono::seconds(30));
      auto self = shared_from_this();
      http::async_read(stream, buffer, request, [self](beast::error_code ec, std::size_t) {
        if (!ec)
          self->handle();
      });
    }

    void reply(http::status status, std::string body, const char *type, const std::string &set_cookie = "")
    {
      auto response = std::make_shared<http::response<http::string_body>>(status, request.version());
      response->set(http::field::server, "modal-rt view");
      response->set(http::field::content_type, type);
      response->set(http::field::cache_control, "no-store");
      // The page runs its own scripts only (no inline script, no eval), talks to its own server only,
      // and is framed by no other page.
      response->set("Content-Security-Policy",
                    "default-src 'self'; script-src 'self'; connect-src 'self'; style-src 'self' 'unsafe-inline'; "
                    "img-src 'self' data:; object-src 'none'; base-uri 'none'; frame-ancestors 'none'");
      response->set("X-Content-Type-Options", "nosniff");
      if (!set_cookie.empty())
        response->set(http::field::set_cookie, set_cookie);
      response->keep_alive(request.keep_alive());
      response->body() = std::move(body);
      response->prepare_payload();
      auto self = shared_from_this();
      http::async_write(stream, *response, [self, response](beast::error_code ec, std::size_t) {
        if (!ec && response->keep_alive())
          self->read();
        else
          self->stream.socket().shutdown(tcp::socket::shutdown_send, ec);
      });
    }

    RequestCredentials credentials(const std::string &query) const
    {
      const auto header = [this](const std::string &name) { return std::string(request[name]); };
      RequestCredentials c;
      c.host           = header("Host");
      c.origin         = header("Origin");
      c.sec_fetch_site = header("Sec-Fetch-Site");
      c.token_header   = header("X-Modal-RT-Token");
      c.token_query    = field_value(query, "token", '&');
      c.cookie         = header("Cookie");
      return c;
    }

    // The address the connection arrived at (an IPv4 client of a [::] listener as IPv4).
    std::string local_address()
    {
      beast::error_code ec;
      auto              address = stream.socket().local_endpoint(ec).address();
      if (ec)
        return "";
      if (address.is_v6() && address.to_v6().is_v4_mapped())
        address = asio::ip::make_address_v4(asio::ip::v4_mapped, address.to_v6());
      return address.to_string();
    }

    void handle()
    {
      std::string       target(request.target());
      const std::size_t query_start = target.find('?');
      const std::string query       = query_start == std::string::npos ? "" : target.substr(query_start + 1);
      if (query_start != std::string::npos)
        target.resize(query_start);
      const RequestCredentials request_credentials = credentials(query);
      const bool   api    = websocket::is_upgrade(request) || target == "/ws" || target.rfind("/api/", 0) == 0;
      const Access access = api ? server.guard->api(request_credentials, local_address())
                                : server.guard->page(request_credentials, local_address());
      if (access != Access::allowed)
        return reply(http::status(access_status(access)), access_reason(access), "text/plain");
      if (websocket::is_upgrade(request))
        {
          if (target != "/ws")
            return reply(http::status::not_found, "no WebSocket at " + target + "\n", "text/plain");
          auto session = std::make_shared<WebSocketSession>(stream.release_socket(), server);
          server.sessions.push_back(session);
          session->start(std::move(request));
          return;
        }
      if (request.method() != http::verb::get && request.method() != http::verb::head)
        return reply(http::status::bad_request, "only GET\n", "text/plain");
      if (target == "/api/info")
        return reply(http::status::ok, server.info_json, "application/json");
      if (target == "/api/basis")
        return reply(http::status::ok, server.basis_bytes, "application/octet-stream");
      if (target == "/api/state")
        return reply(http::status::ok, server.source.state_json(), "application/json");
      if (target == "/api/comparison")
        return server.comparison.empty()
                 ? reply(http::status::not_found, "no design to compare with (modal-rt view --compare B.mrt)\n", "text/plain")
                 : reply(http::status::ok, server.comparison, "application/json");
      if (target == "/api/report")
        return server.has_report ? reply(http::status::ok, server.report, "application/json")
                                 : reply(http::status::not_found, "no report.json beside the basis\n", "text/plain");
      // Static files: the page, and three.js from the npm install (no CDN).
      if (target == "/")
        target = "/index.html";
      if (target.find("..") != std::string::npos)
        return reply(http::status::bad_request, "bad path\n", "text/plain");
      std::filesystem::path file;
      if (target.rfind("/three/", 0) == 0)
        file = std::filesystem::path(server.options.web_root) / "node_modules" / "three" / target.substr(7);
      else if (target == "/index.html" || target == "/view.js" || target == "/access.js")
        file = std::filesystem::path(server.options.web_root) / target.substr(1);
      else
        return reply(http::status::not_found, "not found: " + target + "\n", "text/plain");
      bool        ok   = false;
      std::string body = read_file(file, ok);
      if (!ok)
        return reply(http::status::not_found,
                     "not found: " + file.string() + (target.rfind("/three/", 0) == 0 ? " (run scripts/setup: npm ci in view/web)\n" : "\n"),
                     "text/plain");
      if (target.rfind("/three/examples/jsm/", 0) == 0)
        body = with_three_resolved(std::move(body));
      // The page's load with the right token leaves it in a cookie for its reloads.
      const bool page_with_token = target == "/index.html" && server.guard->api(request_credentials, local_address()) == Access::allowed;
      reply(http::status::ok, std::move(body), content_type(file.string()),
            page_with_token ? server.guard->set_cookie() : std::string());
    }
  };

  void ViewServer::Impl::accept()
  {
    acceptor.async_accept([this](beast::error_code ec, tcp::socket socket) {
      if (ec)
        return;
      std::make_shared<HttpSession>(std::move(socket), *this)->read();
      accept();
    });
  }

  // Server thread: the source's newest frame to every browser.
  void ViewServer::Impl::send_frame()
  {
    sessions.remove_if([](const std::weak_ptr<WebSocketSession> &w) { return w.expired(); });
    frame_bytes.clear();
    if (sessions.empty() || !source.frame(frame_bytes))
      return;
    auto frame = std::make_shared<const std::vector<unsigned char>>(frame_bytes);
    for (auto &w : sessions)
      if (auto s = w.lock())
        s->send_frame(frame);
  }

  ViewServer::ViewServer(const modalrt_basis *basis, const std::string &basis_path, FrameSource &source,
                         ServerOptions options)
    : impl_(std::make_unique<Impl>(basis, basis_path, source, std::move(options)))
  {
    if (impl_->options.web_root.empty())
      impl_->options.web_root = default_web_root();
    const std::vector<unsigned char> bytes = basis_binary(basis, basis_path);
    impl_->basis_bytes.assign(bytes.begin(), bytes.end());
    const ServerOptions &o = impl_->options;
    if (!o.compare_basis.empty())
      impl_->comparison = comparison_json(basis, basis_path, o);
    impl_->info_json = info_json(basis, basis_path, bytes.size(), source.session_json(), o.compare_basis);
    const auto report = std::filesystem::path(basis_path).parent_path() / "report.json";
    impl_->report     = read_file(report, impl_->has_report);
  }

  ViewServer::~ViewServer() { stop(); }

  void ViewServer::start()
  {
    Impl &s = *impl_;
    if (!std::filesystem::exists(std::filesystem::path(s.options.web_root) / "index.html"))
      throw std::runtime_error("view: no index.html in the web root '" + s.options.web_root +
                               "' (set MODAL_RT_VIEW_WEB to the repository's view/web)");
    beast::error_code ec;
    const auto        address = asio::ip::make_address(s.options.address, ec);
    if (ec)
      throw std::runtime_error("view: '" + s.options.address + "' is not an IP address");
    const tcp::endpoint endpoint(address, static_cast<unsigned short>(s.options.port));
    s.acceptor.open(endpoint.protocol(), ec);
    if (!ec)
      s.acceptor.set_option(asio::socket_base::reuse_address(true), ec);
    if (!ec)
      s.acceptor.bind(endpoint, ec);
    if (!ec)
      s.acceptor.listen(asio::socket_base::max_listen_connections, ec);
    if (ec)
      throw std::runtime_error("view: cannot listen on " + s.options.address + ":" + std::to_string(s.options.port) +
                               ": " + ec.message());
    s.bound_port = s.acceptor.local_endpoint().port();
    s.guard      = std::make_unique<AccessGuard>(s.token, s.bound_port, std::vector<std::string>{s.options.address});
    s.accept();
    s.thread = std::thread([&s] { s.io.run(); });
  }

  void ViewServer::stop()
  {
    if (!impl_ || !impl_->thread.joinable())
      return;
    impl_->io.stop();
    impl_->thread.join();
  }

  void ViewServer::publish()
  {
    Impl &s = *impl_;
    asio::post(s.io, [&s] { s.send_frame(); });
  }

  unsigned    ViewServer::port() const { return impl_->bound_port; }
  std::string ViewServer::url() const
  {
    return "http://" + url_host(impl_->options.address) + ":" + std::to_string(impl_->bound_port) +
           "/?token=" + impl_->token;
  }
  std::size_t ViewServer::basis_bytes() const { return impl_->basis_bytes.size(); }
} // namespace modalrt_view
