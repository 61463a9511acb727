// api/openapi.json is kept by hand; these tests hold it to the options table
// (daemon/service/config_keys.h) and to the routes (routes.h), so a range, a
// default, a choice, a route or a job file changed in one is changed in both.
#include "api/openapi.h"

#include <gtest/gtest.h>

#include <set>

#include "api/routes.h"
#include "daemon/service/config_keys.h"

namespace dfsm::api {
namespace {

using nlohmann::json;
using service::ConfigKey;
using service::KeyType;

const json& Schemas() { return OpenApiDocument().at("components").at("schemas"); }

// The schema's statement of a key's type, default, range and choices.
void ExpectSchemaOfKey(const json& schema, const ConfigKey& key, bool with_maximum = true) {
  SCOPED_TRACE(key.name);
  EXPECT_EQ(schema.at("type"), service::TypeName(key.type));
  EXPECT_EQ(schema.at("default"), json::parse(key.ValueText(service::DaemonConfig())));
  if (key.type == KeyType::kInt || key.type == KeyType::kInt64 || key.type == KeyType::kDouble) {
    EXPECT_EQ(schema.at("minimum"), key.min);
    if (with_maximum) {
      EXPECT_EQ(schema.at("maximum"), key.max);
    }
  } else {
    EXPECT_FALSE(schema.contains("minimum") || schema.contains("maximum"));
  }
  if (key.choices.empty()) {
    EXPECT_FALSE(schema.contains("enum"));
  } else {
    EXPECT_EQ(schema.at("enum"), json(key.choices));
  }
}

TEST(OpenApiTest, TheConfigSchemaIsTheOptionsTable) {
  const json& sections = Schemas().at("Config").at("properties");
  size_t documented = 0;
  for (const auto& [section, keys] : sections.items()) {
    for (const auto& [name, schema] : keys.at("properties").items()) {
      const ConfigKey* key = service::FindConfigKey(section + "." + name);
      ASSERT_NE(key, nullptr) << section << "." << name << " is documented but not a key";
      ExpectSchemaOfKey(schema, *key);
      ++documented;
    }
  }
  EXPECT_EQ(documented, service::ConfigKeys().size()) << "a key is missing in openapi.json";
}

// Each field of a job's options names the key whose default, range and
// choices it takes (x-dfsmd-key), as api/job_request.cc applies them.
TEST(OpenApiTest, TheJobOptionsTakeTheirKeysDefaultsAndRanges) {
  int fields_with_keys = 0;
  for (const auto& [field, schema] : Schemas().at("CaptureRequest").at("properties").items()) {
    if (!schema.contains("x-dfsmd-key")) continue;
    const ConfigKey& key = service::ConfigKeyNamed(schema.at("x-dfsmd-key").get<std::string>());
    // frames and max_frames: at most capture.ring_frames, a value of the
    // configuration; frames is an integer or "auto".
    const bool ring_bound = field == "frames" || field == "max_frames";
    if (field == "frames") {
      json integer = schema.at("oneOf").at(0);
      integer["default"] = schema.at("default");
      ExpectSchemaOfKey(integer, key, false);
      EXPECT_EQ(schema.at("oneOf").at(1).at("enum"), json({"auto"}));
    } else {
      ExpectSchemaOfKey(schema, key, !ring_bound);
    }
    ++fields_with_keys;
  }
  EXPECT_EQ(fields_with_keys, 9);
  // The upload's query takes the same fields, "when" excepted.
  for (const json& parameter :
       OpenApiDocument().at("paths").at("/api/v1/jobs").at("post").at("parameters")) {
    const std::string name = parameter.at("name");
    if (name == "frames") continue;  // 0: every frame of the upload
    if (name == "camera") continue;  // uploads only: a capture's is the capture camera
    EXPECT_EQ(parameter.at("schema").at("$ref"),
              "#/components/schemas/CaptureRequest/properties/" + name);
  }
}

TEST(OpenApiTest, EveryRouteIsDocumentedAndNothingElse) {
  std::set<std::string> routes, documented;
  for (const ApiResource& resource : ApiResources()) {
    if (resource.path.rfind("/ui/", 0) == 0) continue;  // the web page's files
    for (const char* method : {"GET", "POST", "DELETE"}) {
      if (resource.methods.find(method) != std::string::npos) {
        routes.insert(std::string(method) + " " + resource.path);
      }
    }
  }
  for (const auto& [path, operations] : OpenApiDocument().at("paths").items()) {
    for (const auto& [method, operation] : operations.items()) {
      if (method == "parameters") continue;
      std::string upper = method;
      for (char& c : upper) c = static_cast<char>(std::toupper(c));
      documented.insert(upper + " " + path);
    }
  }
  EXPECT_EQ(routes, documented);
}

TEST(OpenApiTest, TheJobFilesAreTheRoutesJobFiles) {
  const json& parameters =
      OpenApiDocument().at("paths").at("/api/v1/jobs/{id}/{file}").at("get").at("parameters");
  for (const json& parameter : parameters) {
    if (parameter.at("name") == "file") {
      EXPECT_EQ(parameter.at("schema").at("enum"), json(JobFileNames()));
      return;
    }
  }
  ADD_FAILURE() << "no {file} parameter";
}

}  // namespace
}  // namespace dfsm::api
