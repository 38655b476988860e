#pragma once
// Averaging restarts (issue #36): the mean of several neural state-space models' outputs is itself one
// neural state-space model — their states side by side — so the average is stored, validated, analysed,
// diagnosed and designed on as any other ss model; and the members of an average chosen by validation J.

#include <Eigen/Core>
#include <optional>
#include <string>
#include <vector>

#include "models/state_space_nn/ss_model.h"

namespace panelbass::models {

/// The ss model whose output is the mean of `members`' outputs: x = [x₁; …; x_K], A block-diagonal, B, the
/// encoders (E, c2, V1, c1, V2 block-wise) and the nodes of [f; h] stacked (each node reads its own member's
/// states and the input, and feeds its own member's states), C, D and h's weights and bias divided by K.
/// Members must share fs, scaling (the same estimation data), lags and activation, and carry no polynomial;
/// std::invalid_argument names the member and what differs. Their meta is kept under meta["members"]; their
/// fitted initial states (state_prior) are not: the average starts from its encoders.
SsModel ss_average(const std::vector<SsModel>& members);

/// Why `m` cannot sit beside `first` in one average ("has another scaling than the first …", for a message
/// that names `m`), or nullopt when it can; `first` against itself checks it alone (a polynomial).
std::optional<std::string> ss_average_mismatch(const SsModel& first, const SsModel& m);

/// The members of an average chosen by J (forward selection, as Caruana et al. 2004): the candidate of lowest
/// J first, then each time the one whose addition leaves the mean of the lowest J, until all are in; the
/// members are the first ones of that order up to the lowest J on the way (a member that raises J one step
/// may still let a later one lower it below what came before).
struct AverageSelection {
  std::vector<int> order;         ///< every candidate's index, in the order they were added
  std::vector<double> j_percent;  ///< [2A] J of the mean of the first 1, 2, … of `order`
  std::vector<int> chosen;        ///< the members: the first of `order` up to the lowest of `j_percent`
  std::vector<double> candidate_j_percent;  ///< each candidate's own J
};

/// Greedy forward selection over candidates' free runs `runs` (each the length of `y`, raw units) against
/// the measured `y`, J over k ≥ `init` — the J the models report. Throws std::invalid_argument for no
/// candidates or a run whose length differs from y's (naming its index) or that is not finite.
AverageSelection select_average(const std::vector<Eigen::VectorXd>& runs, const Eigen::VectorXd& y, Eigen::Index init);

}  // namespace panelbass::models
