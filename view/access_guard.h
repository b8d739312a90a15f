// Who may use the live view (docs/reliability.md, "Threat model: the live view"): the rules the
// server applies to every request before it answers, as pure functions of the request's headers,
// so that they read (and are tested) apart from the HTTP code.
//
//   - Host: one of the names the server is reached by, with its port: 127.0.0.1, localhost, [::1],
//     the --address it listens on, or the address the connection arrived at. Anything else (a
//     DNS-rebinding page's own name) is refused with 403, the page and its scripts too.
//   - /ws and /api/*: same origin only (Origin, when present, is http://HOST of the request;
//     Sec-Fetch-Site, when present, is same-origin or none), and the run's token, compared in
//     constant time, from the X-Modal-RT-Token header, the token= query parameter, or the cookie the
//     page's load set. The cookie counts only with a same-origin sign (Origin or Sec-Fetch-Site):
//     a client that sends neither (no browser) must carry the token itself.
#pragma once

#include <string>
#include <vector>

namespace modalrt_view
{
  // What the guard reads of a request (empty: absent).
  struct RequestCredentials
  {
    std::string host;           // Host
    std::string origin;         // Origin
    std::string sec_fetch_site; // Sec-Fetch-Site
    std::string token_header;   // X-Modal-RT-Token
    std::string token_query;    // token= of the target's query
    std::string cookie;         // Cookie (all of it)
  };

  enum class Access
  {
    allowed,
    bad_host,     // 403
    cross_origin, // 403
    no_token,     // 401
    wrong_token,  // 403
  };

  class AccessGuard
  {
  public:
    // `token`: this run's secret (random_token()); `port`: the bound port; `names`: the hosts the
    // server is reached by besides the loopback names (the --address, as an IP address).
    AccessGuard(std::string token, unsigned port, const std::vector<std::string> &names);

    // A file of the page: the Host only. `local_address`: the address the connection arrived at.
    Access page(const RequestCredentials &request, const std::string &local_address) const;
    // /ws and /api/*: Host, origin and token.
    Access api(const RequestCredentials &request, const std::string &local_address) const;

    const std::string &token() const { return token_; }
    // The cookie the page's load sets: per port, since a browser keeps cookies per host, not port.
    std::string cookie_name() const;
    std::string set_cookie() const; // the Set-Cookie value: SameSite=Strict; HttpOnly; Path=/

  private:
    bool host_allowed(const std::string &host, const std::string &local_address) const;
    bool token_matches(const std::string &candidate) const;

    std::string              token_;
    unsigned                 port_;
    std::vector<std::string> names_; // the loopback names and the server's addresses, without the port
  };

  // A new secret: 256 bits from /dev/urandom (std::random_device where it cannot be read), as hex.
  std::string random_token();
  // The status and the short reason of a refusal.
  int         access_status(Access access);
  const char *access_reason(Access access);
  // The value of `name` in a Cookie header or a query string (`separator` ';' or '&'); "" if absent.
  std::string field_value(const std::string &fields, const std::string &name, char separator);
  // An IP address as a URL's host: an IPv6 address in brackets.
  std::string url_host(const std::string &address);
} // namespace modalrt_view
