#include "access_guard.h"

#include <algorithm>
#include <cctype>
#include <cstdio>
#include <fstream>
#include <random>

namespace modalrt_view
{
  namespace
  {
    std::string lower(std::string text)
    {
      std::transform(text.begin(), text.end(), text.begin(), [](unsigned char c) { return char(std::tolower(c)); });
      return text;
    }

    std::string trimmed(const std::string &text)
    {
      const auto first = text.find_first_not_of(" \t");
      const auto last  = text.find_last_not_of(" \t");
      return first == std::string::npos ? std::string() : text.substr(first, last - first + 1);
    }
  } // namespace

  std::string url_host(const std::string &address)
  {
    return address.find(':') != std::string::npos && address.front() != '[' ? "[" + address + "]" : address;
  }

  std::string random_token()
  {
    unsigned char bytes[32];
    std::ifstream urandom("/dev/urandom", std::ios::binary);
    if (!urandom.read(reinterpret_cast<char *>(bytes), sizeof bytes))
      {
        std::random_device device;
        for (unsigned char &b : bytes)
          b = static_cast<unsigned char>(device());
      }
    std::string hex;
    char        pair[3];
    for (unsigned char b : bytes)
      std::snprintf(pair, sizeof pair, "%02x", b), hex += pair;
    return hex;
  }

  AccessGuard::AccessGuard(std::string token, unsigned port, const std::vector<std::string> &names)
    : token_(std::move(token)), port_(port), names_{"127.0.0.1", "localhost", "::1"}
  {
    names_.insert(names_.end(), names.begin(), names.end());
  }

  bool AccessGuard::host_allowed(const std::string &host, const std::string &local_address) const
  {
    const std::string requested = lower(trimmed(host));
    const auto        reached_as = [&](const std::string &name) {
      const std::string form = lower(url_host(name));
      // A browser leaves the default port out.
      return requested == form + ":" + std::to_string(port_) || (port_ == 80 && requested == form);
    };
    return (!local_address.empty() && reached_as(local_address)) || std::any_of(names_.begin(), names_.end(), reached_as);
  }

  // Constant time in the candidate's bytes: every byte is compared, whatever the first difference.
  bool AccessGuard::token_matches(const std::string &candidate) const
  {
    if (token_.empty())
      return false;
    unsigned difference = candidate.size() == token_.size() ? 0u : 1u;
    for (std::size_t i = 0; i < candidate.size(); ++i)
      difference |= unsigned(static_cast<unsigned char>(candidate[i]) ^
                             static_cast<unsigned char>(token_[i % token_.size()]));
    return difference == 0;
  }

  Access AccessGuard::page(const RequestCredentials &request, const std::string &local_address) const
  {
    return host_allowed(request.host, local_address) ? Access::allowed : Access::bad_host;
  }

  Access AccessGuard::api(const RequestCredentials &request, const std::string &local_address) const
  {
    if (!host_allowed(request.host, local_address))
      return Access::bad_host;
    const bool origin_same = !request.origin.empty() && lower(trimmed(request.origin)) == "http://" + lower(trimmed(request.host));
    if (!request.origin.empty() && !origin_same)
      return Access::cross_origin;
    const std::string site = lower(trimmed(request.sec_fetch_site));
    if (!site.empty() && site != "same-origin" && site != "none")
      return Access::cross_origin;
    std::string token = !request.token_header.empty() ? trimmed(request.token_header) : request.token_query;
    if (token.empty() && (origin_same || site == "same-origin"))
      token = field_value(request.cookie, cookie_name(), ';');
    if (token.empty())
      return Access::no_token;
    return token_matches(token) ? Access::allowed : Access::wrong_token;
  }

  std::string AccessGuard::cookie_name() const { return "modal_rt_token_" + std::to_string(port_); }

  std::string AccessGuard::set_cookie() const
  {
    return cookie_name() + "=" + token_ + "; Path=/; SameSite=Strict; HttpOnly";
  }

  int access_status(Access access)
  {
    return access == Access::allowed ? 200 : access == Access::no_token ? 401 : 403;
  }

  const char *access_reason(Access access)
  {
    switch (access)
      {
        case Access::allowed:
          return "";
        case Access::bad_host:
          return "refused: the Host header is not an address this server listens on\n";
        case Access::cross_origin:
          return "refused: a request from another origin\n";
        case Access::no_token:
          return "refused: no token (open the URL with ?token=... that modal-rt printed)\n";
        case Access::wrong_token:
          return "refused: wrong token\n";
      }
    return "refused\n";
  }

  std::string field_value(const std::string &fields, const std::string &name, char separator)
  {
    std::size_t start = 0;
    while (start <= fields.size())
      {
        const std::size_t end   = std::min(fields.find(separator, start), fields.size());
        const std::string field = trimmed(fields.substr(start, end - start));
        if (field.size() > name.size() && field.compare(0, name.size(), name) == 0 && field[name.size()] == '=')
          return field.substr(name.size() + 1);
        start = end + 1;
      }
    return "";
  }
} // namespace modalrt_view
