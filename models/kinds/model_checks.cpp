#include "models/kinds/model_checks.h"

#include <cmath>
#include <cstdint>
#include <stdexcept>
#include <vector>

#include "models/io/network_fields.h"
#include "models/io/number_text.h"
#include "models/linear/extended_precision.h"
#include "models/preprocess/scaling.h"

namespace panelbass::models {
namespace {

using nlohmann::json;

// A JSON array of numbers as a vector; throws (any exception: the loader names the problem) otherwise.
Eigen::VectorXd numbers_of(const json& v) {
  if (!v.is_array()) throw std::invalid_argument("not an array");
  Eigen::VectorXd out(static_cast<Eigen::Index>(v.size()));
  for (std::size_t i = 0; i < v.size(); ++i) {
    if (!v[i].is_number()) throw std::invalid_argument("not a number");
    out[static_cast<Eigen::Index>(i)] = v[i].get<double>();
  }
  return out;
}

}  // namespace

std::optional<double> unstable_lq_radius(const Eigen::MatrixXd& A, const Eigen::VectorXd& B, const Eigen::VectorXd& L) {
  const Eigen::MatrixXd loop = A - B * L.transpose();
  const double radius = static_cast<double>(extended::spectral_radius(loop.cast<extended::Real>()));
  if (radius < 1.0) return std::nullopt;
  return radius;
}

std::optional<Runaway> closed_loop_runaway(const NeuralFeedback& c) {
  const ClosedLoopRun run = simulate_closed_loop(c, free_run_drive());
  return runaway(c.plant.scaling().scale_y(run.y));
}

std::optional<std::pair<std::string, double>> first_non_finite(const json& root, const std::string& root_path) {
  std::vector<std::pair<const json*, std::string>> stack{{&root, root_path}};
  while (!stack.empty()) {
    auto [value, path] = std::move(stack.back());
    stack.pop_back();
    if (value->is_number_float()) {
      const double v = value->get<double>();
      if (!std::isfinite(v)) return std::pair{path, v};
    } else if (value->is_object()) {
      std::vector<std::pair<const json*, std::string>> children;
      for (auto it = value->begin(); it != value->end(); ++it) children.emplace_back(&*it, path + "." + it.key());
      stack.insert(stack.end(), children.rbegin(), children.rend());
    } else if (value->is_array()) {
      for (std::size_t i = value->size(); i-- > 0;) {
        stack.emplace_back(&(*value)[i], path + "[" + std::to_string(i) + "]");
      }
    }
  }
  return std::nullopt;
}

std::optional<std::string> runaway_problem(const std::optional<Runaway>& run, const std::string& path, const std::string& what) {
  if (!run) return std::nullopt;
  return path + ": unstable: " + what + " on uniform noise leaves ±" + number_text(kFreeRunBound) +
         " output ranges (|y| = " + number_text(run->magnitude) + " after " + std::to_string(run->samples) + " samples)";
}

std::optional<std::string> linear_unsafety(const json& file) {
  try {
    TransferFunction tf;
    tf.a = numbers_of(file.at("params").at("a"));
    tf.b = Eigen::VectorXd::Ones(1);
    const double fs = file.contains("fs") && file["fs"].is_number() ? file["fs"].get<double>() : NAN;
    const std::optional<UnstablePole> pole = unstable_pole(tf, fs);
    if (!pole) return std::nullopt;
    return "model.params.a: unstable: pole at |z| = " + number_text(pole->radius) +
           (std::isfinite(pole->hz) ? " (" + number_text(pole->hz) + " Hz)" : "");
  } catch (...) {
    return std::nullopt;  // malformed: the loader names it
  }
}

std::optional<std::string> lq_unsafety(const json& file) {
  try {
    const json& params = file.at("params");
    const json& a = params.at("A");
    if (!a.is_array()) return std::nullopt;
    const auto n = static_cast<Eigen::Index>(a.size());
    Eigen::MatrixXd A(n, n);
    for (Eigen::Index r = 0; r < n; ++r) {
      const Eigen::VectorXd row = numbers_of(a[static_cast<std::size_t>(r)]);
      if (row.size() != n) return std::nullopt;
      A.row(r) = row.transpose();
    }
    const Eigen::VectorXd B = numbers_of(params.at("B"));
    const Eigen::VectorXd L = numbers_of(params.at("L"));
    if (B.size() != n || L.size() != n || n == 0) return std::nullopt;
    const std::optional<double> radius = unstable_lq_radius(A, B, L);
    if (!radius) return std::nullopt;
    return "model.params: unstable: pole of A − B·L at |z| = " + number_text(*radius);
  } catch (...) {
    return std::nullopt;
  }
}

std::optional<std::string> narx_unsafety(const json& file, const std::string& path) {
  try {
    const Scaling scaling = scaling_from_json(file.at("scaling"), path + ".scaling");
    const json& params = file.at("params");
    NarxStructure s;
    // Orders beyond these are a corrupt file (the loader's limits say which).
    const auto order = [&params](const char* key, std::int64_t hi) {
      const json& v = params.at(key);
      if (!v.is_number_integer()) throw std::invalid_argument("not an integer");
      const std::int64_t n = v.get<std::int64_t>();
      if (n < 0 || n > hi) throw std::invalid_argument("out of range");
      return static_cast<int>(n);
    };
    s.na = order("na", 999);
    s.nb = order("nb", 999);
    // Any delay of the whole run or more gives the same run: the input never arrives.
    s.nk = static_cast<int>(std::min<std::int64_t>(order("nk", 384000L * 60L), kFreeRunSamples));
    if (s.inputs() > 1000) return std::nullopt;
    s.hidden = read_hidden(params.contains("hidden") ? &params["hidden"] : nullptr, path + ".params.hidden");
    const std::int64_t count = parameter_count(s.inputs(), s.hidden);
    const Eigen::VectorXd theta = read_theta(params.contains("theta") ? &params["theta"] : nullptr, path + ".params.theta", count);
    NarxModel m = NarxModel::with_structure(s, scaling, 1.0);
    m.net.parameters() = theta;
    return runaway_problem(free_run_runaway(m), path, "the free run");
  } catch (...) {
    return std::nullopt;
  }
}

}  // namespace panelbass::models
