// Every field of a use case's request is documented where a client of the API reads it: in the OpenAPI document's
// params schema of its job kind and in api/ROUTES.md's entry for that kind. The test names each field one of them
// lacks, so a field added to a request struct without its documentation fails here.
#include <gtest/gtest.h>

#include <fstream>
#include <sstream>
#include <string>
#include <vector>

#include "api/jobs/job_kinds.h"
#include "api/server.h"
#include "models/kinds/model_file.h"
#include "usecases/analyze.h"
#include "usecases/design_lq.h"
#include "usecases/design_mirror.h"
#include "usecases/design_nn.h"
#include "usecases/diagnose.h"
#include "usecases/excite.h"
#include "usecases/harmonics.h"
#include "usecases/identify_average.h"
#include "usecases/identify_mimo.h"
#include "usecases/identify_oscillator.h"
#include "usecases/equal_output_thd.h"
#include "usecases/evaluate.h"
#include "usecases/identify_linear.h"
#include "usecases/identify_narx.h"
#include "usecases/identify_ss.h"
#include "usecases/plant_survey.h"
#include "usecases/tune.h"
#include "usecases/validate_model.h"
#include "usecases/verify.h"

namespace panelbass::api {
namespace {

using nlohmann::json;

// The leaf fields of a request's JSON, as dotted paths ("band_pass.low_hz"); an object-valued field counts too.
void field_paths(const json& j, const std::string& prefix, std::vector<std::string>& out) {
  for (const auto& [key, value] : j.items()) {
    const std::string path = prefix.empty() ? key : prefix + "." + key;
    out.push_back(path);
    if (value.is_object()) field_paths(value, path, out);
  }
}

// The schema of `path` within the params schema `schema` (nested "properties"), or null.
const json* schema_of(const json& schema, const std::string& path) {
  const json* at = &schema;
  std::size_t start = 0;
  while (true) {
    const std::size_t dot = path.find('.', start);
    const std::string key = path.substr(start, dot == std::string::npos ? std::string::npos : dot - start);
    if (!at->contains("properties") || !(*at)["properties"].contains(key)) return nullptr;
    at = &(*at)["properties"][key];
    if (dot == std::string::npos) return at;
    start = dot + 1;
  }
}

// ROUTES.md's entry of job kind `kind`: from "  - `kind`:" to the next entry of the list.
std::string routes_entry(const std::string& kind) {
  std::ifstream in(std::string(PANELBASS_SOURCE_DIR) + "/api/ROUTES.md");
  std::stringstream text;
  text << in.rdbuf();
  const std::string all = text.str();
  const std::size_t start = all.find("  - `" + kind + "`:");
  if (start == std::string::npos) return "";
  const std::size_t end = all.find("\n  - `", start + 1);
  return all.substr(start, end == std::string::npos ? std::string::npos : end - start);
}

struct DocumentedRequest {
  const char* kind;    ///< the job kind
  const char* schema;  ///< its params schema in the OpenAPI document
  json fields;         ///< the request struct's fields with their defaults
};

TEST(RequestDocs, EveryRequestFieldIsInTheOpenApiSchemaAndRoutesEntryOfItsJobKind) {
  const std::vector<DocumentedRequest> requests = {
      {"design-lq", "DesignLqParams", usecases::to_json(usecases::DesignLqRequest{})},
      {"validate", "ValidateParams", usecases::to_json(usecases::ValidateRequest{})},
      {"design-mirror", "DesignMirrorParams", usecases::to_json(usecases::DesignMirrorRequest{})},
      {"harmonics", "HarmonicsParams", usecases::to_json(usecases::HarmonicsRequest{})},
      {"diagnose", "DiagnoseParams", usecases::to_json(usecases::DiagnoseRequest{})},
      {"identify-oscillator", "IdentifyOscillatorParams", usecases::to_json(usecases::IdentifyOscillatorRequest{})},
      {"identify-ss", "IdentifySsParams", usecases::to_json(usecases::IdentifySsRequest{})},
      {"identify-average", "IdentifyAverageParams", usecases::to_json(usecases::IdentifyAverageRequest{})},
      {"identify-mimo", "IdentifyMimoParams", usecases::to_json(usecases::IdentifyMimoRequest{})},
      {"tune", "TuneParams", usecases::to_json(usecases::TuneRequest{})},
      {"verify", "VerifyParams", usecases::to_json(usecases::VerifyRequest{})},
      {"design-nn", "DesignNnParams", usecases::to_json(usecases::DesignNnRequest{})},
      {"excite", "ExciteParams", usecases::to_json(usecases::ExciteRequest{.signal = "control"})},
      {"plant-survey", "PlantSurveyParams", usecases::to_json(usecases::PlantSurveyRequest{})},
      {"identify-linear", "IdentifyLinearParams", usecases::to_json(usecases::IdentifyLinearRequest{})},
      {"identify-narx", "IdentifyNarxParams", usecases::to_json(usecases::IdentifyNarxRequest{})},
      {"analyze", "AnalyzeParams", usecases::to_json(usecases::AnalyzeRequest{})},
      {"evaluate", "EvaluateParams", usecases::to_json(usecases::EvaluateRequest{})},
  };
  const json& schemas = openapi_document().at("components").at("schemas");
  for (const DocumentedRequest& r : requests) {
    ASSERT_TRUE(schemas.contains(r.schema)) << "the OpenAPI document has no schema " << r.schema << " for " << r.kind;
    const std::string entry = routes_entry(r.kind);
    ASSERT_FALSE(entry.empty()) << "api/ROUTES.md has no entry for the job kind " << r.kind;
    std::vector<std::string> paths;
    field_paths(r.fields, "", paths);
    ASSERT_FALSE(paths.empty()) << r.kind;
    for (const std::string& path : paths) {
      EXPECT_NE(schema_of(schemas.at(r.schema), path), nullptr)
          << "the OpenAPI schema " << r.schema << " lacks the field " << path << " of " << r.kind << "'s request";
      const std::string leaf = path.substr(path.rfind('.') == std::string::npos ? 0 : path.rfind('.') + 1);
      EXPECT_TRUE(entry.find("`" + leaf + "`") != std::string::npos || entry.find("\"" + leaf + "\"") != std::string::npos)
          << "api/ROUTES.md's entry of " << r.kind << " does not mention the field " << path << " (as `" << leaf
          << "` or \"" << leaf << "\")";
    }
  }
}

// A job kind whose params are read by its job (identify-narx, its restarts a use case's request): every param the job
// fills in is in the OpenAPI schema and the ROUTES.md entry of its kind, with the schema's default the job's.
TEST(RequestDocs, EveryIdentifyNarxParamIsDocumentedWithTheJobsDefault) {
  JobEnvironment env;
  env.excite = [](const Eigen::VectorXd& drive) { return drive; };  // a backend to excite (the default source)
  const json filled = validate_job_params("identify-narx", json::object(), env);
  const json& schema = openapi_document().at("components").at("schemas").at("IdentifyNarxParams");
  const std::string entry = routes_entry("identify-narx");
  ASSERT_FALSE(entry.empty());
  ASSERT_TRUE(filled.contains("restarts")) << filled;
  for (const auto& [field, value] : filled.items()) {
    const json* documented = schema_of(schema, field);
    ASSERT_NE(documented, nullptr) << "the OpenAPI schema IdentifyNarxParams lacks the param " << field;
    if (documented->contains("default")) EXPECT_EQ(documented->at("default"), value) << field;
    // The data's source is written "record|excite" in every entry that takes one (ROUTES.md "record" says how).
    const bool source = (field == "record" || field == "excite") && entry.find("record|excite") != std::string::npos;
    EXPECT_TRUE(source || entry.find("`" + field + "`") != std::string::npos ||
                entry.find("\"" + field + "\"") != std::string::npos)
        << "api/ROUTES.md's entry of identify-narx does not mention the param " << field;
  }
}

// The OpenAPI document's model kinds are the registry's (models/kinds/model_file.h), in its order.
TEST(RequestDocs, TheModelFileKindsAreTheRegistrys) {
  std::vector<std::string> registry;
  for (const models::ModelKind& k : models::model_kinds()) registry.emplace_back(k.name);
  const json& kinds = openapi_document().at("components").at("schemas").at("ModelFile").at("properties").at("kind").at("enum");
  EXPECT_EQ(kinds.get<std::vector<std::string>>(), registry);
}

// The check above can fail: a field the documents lack is found.
TEST(RequestDocs, AFieldTheDocumentsLackIsFound) {
  const json& schema = openapi_document().at("components").at("schemas").at("DesignLqParams");
  EXPECT_EQ(schema_of(schema, "no_such_field"), nullptr);
  EXPECT_EQ(schema_of(schema, "band_pass.no_such_corner"), nullptr);
  EXPECT_NE(schema_of(schema, "band_pass.low_hz"), nullptr);
  EXPECT_EQ(routes_entry("no-such-kind"), "");
}

}  // namespace
}  // namespace panelbass::api
