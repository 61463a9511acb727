// The OpenAPI 3.0 description of the REST API, served at /api/v1/openapi.json.
#pragma once

#include <nlohmann/json.hpp>

namespace dfsm::api {

nlohmann::json OpenApiDocument();

}  // namespace dfsm::api
