#include "api/jobs/excitation_record.h"

#include <cmath>
#include <stdexcept>

#include "api/jobs/param_reader.h"
#include "dsp/sample_rate.h"
#include "models/io/json_fields.h"
#include "models/io/number_text.h"

namespace panelbass::api {
namespace {

using nlohmann::json;

// For a `where` that already names its subject ("params.record: job j3"): "<where> <what>".
[[noreturn]] void fail_after(const std::string& where, const std::string& what) { throw std::invalid_argument(where + " " + what); }

Eigen::VectorXd numbers_of(const json& record, const char* name, const std::string& where) {
  const auto it = record.find(name);
  if (it == record.end() || !it->is_array()) fail_after(where, std::string("has no array record.") + name);
  Eigen::VectorXd x(static_cast<Eigen::Index>(it->size()));
  Eigen::Index k = 0;
  for (const json& v : *it) {
    if (!v.is_number() || !std::isfinite(v.get<double>())) {
      fail_after(where, std::string("has a non-finite record.") + name + "[" + std::to_string(k) + "]");
    }
    x[k++] = v.get<double>();
  }
  return x;
}

}  // namespace

json excitation_record_to_json(const ExcitationRecord& record) {
  json out = {{"u_est", models::to_array(record.u_est)},
              {"y_est", models::to_array(record.y_est)},
              {"u_val", models::to_array(record.u_val)},
              {"y_val", models::to_array(record.y_val)}};
  if (record.w_est.size() > 0) {
    out["w_est"] = models::to_array(record.w_est);
    out["w_val"] = models::to_array(record.w_val);
  }
  if (record.i_est.size() > 0) {
    out["i_est"] = models::to_array(record.i_est);
    out["i_val"] = models::to_array(record.i_val);
  }
  if (record.l_est.size() > 0) {
    out["l_est"] = models::to_array(record.l_est);
    out["l_val"] = models::to_array(record.l_val);
  }
  return out;
}

ExcitationRecord excitation_record_from_result(const json& result, double fs, const std::string& where) {
  if (!result.is_object() || !result.contains("record") || !result.at("record").is_object()) {
    fail_after(where, "is not an excite job (its result has no \"record\")");
  }
  const json& record = result.at("record");
  ExcitationRecord out;
  out.u_est = numbers_of(record, "u_est", where);
  out.y_est = numbers_of(record, "y_est", where);
  out.u_val = numbers_of(record, "u_val", where);
  out.y_val = numbers_of(record, "y_val", where);
  if (out.u_est.size() != out.y_est.size() || out.u_val.size() != out.y_val.size()) {
    fail_after(where, "has a record whose drive and response differ in length");
  }
  if (record.contains("w_est")) {
    out.w_est = numbers_of(record, "w_est", where);
    out.w_val = numbers_of(record, "w_val", where);
    if (out.w_est.size() != out.u_est.size() || out.w_val.size() != out.u_val.size()) {
      fail_after(where, "has a record whose weights and drive differ in length");
    }
    if ((out.w_est.array() < 0.0).any() || (out.w_val.array() < 0.0).any()) {
      fail_after(where, "has a record with a negative weight");
    }
  }
  // Channels beside the drive, each as long as it: the current, the converters' output.
  const auto beside = [&](const char* est, const char* val, const char* what, Eigen::VectorXd& e, Eigen::VectorXd& v) {
    if (!record.contains(est)) return;
    e = numbers_of(record, est, where);
    v = numbers_of(record, val, where);
    if (e.size() != out.u_est.size() || v.size() != out.u_val.size()) {
      fail_after(where, std::string("has a record whose ") + what + " and drive differ in length");
    }
  };
  beside("i_est", "i_val", "current", out.i_est, out.i_val);
  beside("l_est", "l_val", "loopback", out.l_est, out.l_val);
  if (out.u_est.size() < kMinSamples) {
    fail_after(where, "has a record of " + std::to_string(out.u_est.size()) + " estimation samples, fewer than " +
                          std::to_string(kMinSamples));
  }
  const auto rate = result.find("fs");
  if (rate != result.end() && (!rate->is_number() || !dsp::same_rate(rate->get<double>(), fs))) {
    fail_after(where, "was recorded at " + shown(*rate) + " Hz, the engine runs at " + models::number_text(fs) + " Hz");
  }
  return out;
}

JudgedPart judged_part(const ExcitationRecord& r) {
  if (r.u_val.size() > 0) return {r.u_val, r.y_val, true};
  return {r.u_est, r.y_est, false};
}

}  // namespace panelbass::api
