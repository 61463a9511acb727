// The OpenAPI 3.0 description of the REST API (api/openapi.json, compiled in),
// served at /api/v1/openapi.json.
#pragma once

#include <nlohmann/json.hpp>

namespace dfsm::api {

const nlohmann::json& OpenApiDocument();

}  // namespace dfsm::api
