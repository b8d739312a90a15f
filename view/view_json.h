// The view's JSON (GET /api/info, GET /api/state): nlohmann's ordered_json, so that a reply keeps the
// order view/README.md documents, dumped with invalid UTF-8 replaced (a path or a space's name is
// bytes) rather than thrown. A non-finite double is written as null.
#pragma once

#include <nlohmann/json.hpp>

#include <string>

namespace modalrt_view
{
  using Json = nlohmann::ordered_json;

  inline std::string dump_json(const Json &json) { return json.dump(-1, ' ', false, Json::error_handler_t::replace); }
} // namespace modalrt_view
