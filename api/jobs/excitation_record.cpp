#include "api/jobs/excitation_record.h"

#include <cmath>
#include <cstdio>
#include <stdexcept>
#include <utility>

#include "api/jobs/param_reader.h"
#include "api/record_store.h"
#include "dsp/data_error.h"
#include "dsp/data_file.h"
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

std::vector<std::string> excitation_record_columns(const ExcitationRecord& record) {
  std::vector<std::string> names{"u", "y"};
  if (record.i_est.size() > 0) names.emplace_back("i");
  if (record.w_est.size() > 0) names.emplace_back("w");
  if (record.l_est.size() > 0) names.emplace_back("l");
  return names;
}

std::string excitation_record_csv(const ExcitationRecord& record) {
  const std::vector<std::string> names = excitation_record_columns(record);
  std::vector<std::pair<const Eigen::VectorXd*, const Eigen::VectorXd*>> parts;
  for (const std::string& n : names) {
    if (n == "u") parts.emplace_back(&record.u_est, &record.u_val);
    if (n == "y") parts.emplace_back(&record.y_est, &record.y_val);
    if (n == "i") parts.emplace_back(&record.i_est, &record.i_val);
    if (n == "w") parts.emplace_back(&record.w_est, &record.w_val);
    if (n == "l") parts.emplace_back(&record.l_est, &record.l_val);
  }
  std::string text;
  for (std::size_t c = 0; c < names.size(); ++c) text += (c ? "," : "") + names[c];
  text += '\n';
  char number[32];
  const auto rows = [&](bool validation) {
    const Eigen::Index n = validation ? record.u_val.size() : record.u_est.size();
    for (Eigen::Index k = 0; k < n; ++k) {
      for (std::size_t c = 0; c < parts.size(); ++c) {
        const Eigen::VectorXd& x = validation ? *parts[c].second : *parts[c].first;
        std::snprintf(number, sizeof number, "%s%.17g", c ? "," : "", x[k]);
        text += number;
      }
      text += '\n';
    }
  };
  rows(false);
  rows(true);
  return text;
}

namespace {

// The record kept in the record store for result {"record_id","record_columns","samples"}: read back and split.
json stored_record_json(const json& result, const std::string& where, const RecordStore* records) {
  const std::string id = result.at("record_id").is_string() ? result.at("record_id").get<std::string>() : "";
  if (records == nullptr) fail_after(where, "keeps its record in a record store this server does not have");
  if (!records->find(id)) fail_after(where, "kept its record as " + id + ", which is no longer stored");
  if (!result.contains("record_columns") || !result.contains("samples") || !result.at("samples").is_number_integer()) {
    fail_after(where, "has a record_id without its record_columns and samples");
  }
  const std::vector<std::string> names = result.at("record_columns").get<std::vector<std::string>>();
  dsp::Record data;
  try {
    data = dsp::read_data_file(records->file(id), names, records->find(id)->fs, 1);
  } catch (const dsp::DataError& e) {
    fail_after(where, "kept its record as " + id + ", which can no longer be read (" + e.what() + ")");
  }
  const auto samples = result.at("samples").get<Eigen::Index>();
  if (samples < 0 || samples > static_cast<Eigen::Index>(data.samples())) fail_after(where, "splits its record beyond its " + std::to_string(data.samples()) + " samples");
  json out = json::object();
  for (std::size_t c = 0; c < names.size(); ++c) {
    const Eigen::VectorXd& x = data.columns[c];
    out[names[c] + "_est"] = models::to_array(x.head(samples));
    out[names[c] + "_val"] = models::to_array(x.tail(x.size() - samples));
  }
  return out;
}

}  // namespace

ExcitationRecord excitation_record_from_result(const json& result, double fs, const std::string& where,
                                               const RecordStore* records) {
  const bool stored = result.is_object() && result.contains("record_id") && !result.contains("record");
  if (!stored && (!result.is_object() || !result.contains("record") || !result.at("record").is_object())) {
    fail_after(where, "is not an excite job (its result has no \"record\")");
  }
  const json kept = stored ? stored_record_json(result, where, records) : json();
  const json& record = stored ? kept : result.at("record");
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
