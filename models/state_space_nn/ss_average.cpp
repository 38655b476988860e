#include "models/state_space_nn/ss_average.h"

#include <algorithm>
#include <cmath>
#include <limits>
#include <stdexcept>
#include <string>

#include "models/validation/performance.h"

namespace panelbass::models {
std::optional<std::string> ss_average_mismatch(const SsModel& first, const SsModel& m) {
  const SsStructure &a = first.structure, &b = m.structure;
  if (b.poly_degree != 0) return "has a polynomial (poly_degree " + std::to_string(b.poly_degree) + "); only tanh or cubic nodes average";
  if (m.fs != first.fs) return "has fs " + std::to_string(m.fs) + ", the first " + std::to_string(first.fs);
  if (b.lags != a.lags) return "reads " + std::to_string(b.lags) + " lags, the first " + std::to_string(a.lags);
  if (b.activation != a.activation) {
    return std::string("has ") + ss_activation_name(b.activation) + " nodes, the first " + ss_activation_name(a.activation);
  }
  const Scaling &s = first.scaling, &t = m.scaling;
  if (s.u_offset != t.u_offset || s.u_scale != t.u_scale || s.y_offset != t.y_offset || s.y_scale != t.y_scale) {
    return "has another scaling than the first (models trained on other data); average models trained on the same "
           "estimation data";
  }
  return std::nullopt;
}

SsModel ss_average(const std::vector<SsModel>& members) {
  if (members.empty()) throw std::invalid_argument("ss_average: no members");
  SsStructure s = members[0].structure;
  s.states = s.hidden = s.encoder_hidden = 0;
  s.hidden_input = false;
  for (std::size_t i = 0; i < members.size(); ++i) {
    if (const auto why = ss_average_mismatch(members[0], members[i])) {
      throw std::invalid_argument("ss_average: member " + std::to_string(i + 1) + " " + *why);
    }
    s.states += members[i].structure.states;
    s.hidden += members[i].structure.hidden;
    s.encoder_hidden += members[i].structure.encoder_hidden;
    s.hidden_input = s.hidden_input || members[i].structure.hidden_input;
  }
  if (s.states > 64) {
    throw std::invalid_argument("ss_average: the " + std::to_string(members.size()) + " members have " +
                                std::to_string(s.states) + " states in all, more than the 64 an ss model holds; average fewer");
  }
  s.check();
  SsModel out;
  out.structure = s;
  out.scaling = members[0].scaling;
  out.fs = members[0].fs;
  out.theta = Eigen::VectorXd::Zero(s.parameter_count());
  auto p = ss_parts(s, out.theta.data());
  const double share = 1.0 / static_cast<double>(members.size());
  const Eigen::Index n = s.states;
  Eigen::Index x0 = 0, h0 = 0, e0 = 0;  // where member i's states, nodes and encoder nodes start
  out.meta["members"] = nlohmann::json::array();
  for (const SsModel& m : members) {
    const auto q = ss_parts(m.structure, m.theta.data());
    const Eigen::Index nx = m.structure.states, h = m.structure.hidden, e = m.structure.encoder_hidden;
    p.A.block(x0, x0, nx, nx) = q.A;
    p.B.middleRows(x0, nx) = q.B;
    p.C.middleCols(x0, nx) = share * q.C;
    p.D(0, 0) += share * q.D(0, 0);
    // the nodes: W1 reads the member's states and the input, W2 feeds its states and (a share of) h
    p.W1.block(h0, x0, h, nx) = q.W1.leftCols(nx);
    if (m.structure.hidden_input) p.W1.block(h0, n, h, 1) = q.W1.col(nx);
    p.b1.middleRows(h0, h) = q.b1;
    p.W2.block(x0, h0, nx, h) = q.W2.topRows(nx);
    p.W2.block(n, h0, 1, h) = share * q.W2.row(nx);
    p.b2.middleRows(x0, nx) = q.b2.topRows(nx);
    p.b2(n, 0) += share * q.b2(nx, 0);
    // the encoder: x(k0) = E·z + V2·tanh(V1·z + c1) + c2, member by member
    p.E.middleRows(x0, nx) = q.E;
    p.c2.middleRows(x0, nx) = q.c2;
    p.V1.middleRows(e0, e) = q.V1;
    p.c1.middleRows(e0, e) = q.c1;
    p.V2.block(x0, e0, nx, e) = q.V2;
    out.meta["members"].push_back(m.meta);
    x0 += nx;
    h0 += h;
    e0 += e;
  }
  return out;
}

AverageSelection select_average(const std::vector<Eigen::VectorXd>& runs, const Eigen::VectorXd& y, Eigen::Index init) {
  if (runs.empty()) throw std::invalid_argument("select_average: no candidates");
  AverageSelection out;
  for (std::size_t i = 0; i < runs.size(); ++i) {
    if (runs[i].size() != y.size()) {
      throw std::invalid_argument("select_average: candidate " + std::to_string(i + 1) + "'s free run has " +
                                  std::to_string(runs[i].size()) + " samples, the data " + std::to_string(y.size()));
    }
    if (!runs[i].allFinite()) throw std::invalid_argument("select_average: candidate " + std::to_string(i + 1) + "'s free run is not finite");
    out.candidate_j_percent.push_back(j_percent(runs[i], y, init));
  }
  Eigen::VectorXd sum = Eigen::VectorXd::Zero(y.size());
  std::vector<bool> taken(runs.size(), false);
  while (out.order.size() < runs.size()) {
    int pick = -1;
    double pick_j = std::numeric_limits<double>::infinity();
    const double k = static_cast<double>(out.order.size() + 1);
    for (std::size_t i = 0; i < runs.size(); ++i) {
      if (taken[i]) continue;
      const double j = j_percent((sum + runs[i]) / k, y, init);
      if (pick < 0 || j < pick_j) {
        pick_j = j;
        pick = static_cast<int>(i);
      }
    }
    taken[static_cast<std::size_t>(pick)] = true;
    sum += runs[static_cast<std::size_t>(pick)];
    out.order.push_back(pick);
    out.j_percent.push_back(pick_j);
  }
  const auto lowest = std::min_element(out.j_percent.begin(), out.j_percent.end()) - out.j_percent.begin();
  out.chosen.assign(out.order.begin(), out.order.begin() + lowest + 1);
  return out;
}

}  // namespace panelbass::models
