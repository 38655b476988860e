#include "models/diagnosis/diagnosis.h"

#include <algorithm>
#include <cmath>
#include <functional>
#include <limits>
#include <memory>
#include <optional>
#include <stdexcept>
#include <utility>

#include "dsp/excitation.h"
#include "models/diagnosis/diagnosis_candidates.h"
#include "models/diagnosis/diagnosis_confidence.h"
#include "models/diagnosis/diagnosis_current.h"
#include "models/diagnosis/diagnosis_explanations.h"
#include "models/diagnosis/diagnosis_levels.h"
#include "models/diagnosis/diagnosis_look_alikes.h"
#include "models/diagnosis/diagnosis_linear_refits.h"
#include "models/diagnosis/diagnosis_pairs.h"
#include "models/diagnosis/diagnosis_stopping.h"
#include "models/linear/linear_identification.h"
#include "models/validation/performance.h"

namespace panelbass::models {
namespace {

using diagnosis_detail::added_correlation;
using diagnosis_detail::candidates;
using diagnosis_detail::Candidate;
using diagnosis_detail::explain;
using diagnosis_detail::confidence_to_json;
using diagnosis_detail::judge_finding;
using diagnosis_detail::look_alikes_of;
using diagnosis_detail::decided_by_current;
using diagnosis_detail::unexplained_residual;
using diagnosis_detail::Fit;
using diagnosis_detail::ForceChannel;
using diagnosis_detail::fit_terms;
using diagnosis_detail::fixed;
using diagnosis_detail::Records;
using diagnosis_detail::refit_linear;
using diagnosis_detail::ruled_out_by_periodic_distortion;
using diagnosis_detail::terms_json;

void check_record(const Eigen::VectorXd& u, const Eigen::VectorXd& y, const std::string& name, Eigen::Index init) {
  if (u.size() != y.size())
    throw std::invalid_argument("diagnose: " + name + " record: input has " + std::to_string(u.size()) +
                                " samples, output " + std::to_string(y.size()));
  if (u.size() < init + 512)
    throw std::invalid_argument("diagnose: " + name + " record: " + std::to_string(u.size()) +
                                " samples; at least " + std::to_string(init + 512) + " needed");
  if (!u.allFinite() || !y.allFinite()) throw std::invalid_argument("diagnose: " + name + " record: a sample is not finite");
}

// The OE model with the lowest validation J over the order scan of `options`, from (u_est, y_est) and
// judged on (u_val, y_val), and the scan as JSON.
std::pair<LinearModel, nlohmann::json> best_linear(const Eigen::VectorXd& u_est, const Eigen::VectorXd& y_est,
                                                   const Eigen::VectorXd& u_val, const Eigen::VectorXd& y_val, double fs,
                                                   const DiagnosisOptions& options) {
  LinearIdentificationSpec spec;
  spec.method = LinearMethod::oe;
  spec.fs = fs;
  spec.init = options.init;
  spec.order = options.scan_to;
  spec.scan_from = options.scan_from;
  spec.scan_to = options.scan_to;
  LinearIdentification id = identify_linear(u_est, y_est, u_val, y_val, spec);
  // The order with the lowest validation J (the scan's own rule allows 5 % more, which would leave
  // a dynamic mismatch for the diagnosis to find).
  int best_order = id.model.tf.na();
  double best_j = std::numeric_limits<double>::infinity();
  for (const auto& e : id.scan)
    if (e.j_val_pct < best_j) best_j = e.j_val_pct, best_order = e.order;
  nlohmann::json scan = nlohmann::json::array();
  for (const auto& e : id.scan) scan.push_back({{"order", e.order}, {"J_val_pct", e.j_val_pct}});
  if (best_order != id.model.tf.na()) {
    spec.scan_from = spec.scan_to = 0;
    spec.order = best_order;
    id = identify_linear(u_est, y_est, u_val, y_val, spec);
  }
  return {id.model, scan};
}

void check_arguments(const Eigen::VectorXd& u_est, const Eigen::VectorXd& y_est, const Eigen::VectorXd& u_val,
                     const Eigen::VectorXd& y_val, double fs, const DiagnosisOptions& options) {
  if (!(fs > 0.0) || !std::isfinite(fs)) throw std::invalid_argument("diagnose: sample rate " + std::to_string(fs) + " Hz is not positive");
  if (options.init < 0) throw std::invalid_argument("diagnose: init must not be negative");
  if (options.lags < 1) throw std::invalid_argument("diagnose: lags must be at least 1");
  check_record(u_est, y_est, "estimation", options.init);
  check_record(u_val, y_val, "validation", options.init);
  for (const LevelRecord& level : options.other_levels) check_record(level.u, level.y, "level record " + level.name, options.init);
  if (options.current_est.size() > 0 || options.current_val.size() > 0) {
    if (options.current_est.size() != u_est.size() || options.current_val.size() != u_val.size())
      throw std::invalid_argument("diagnose: the current has " + std::to_string(options.current_est.size()) + " + " +
                                  std::to_string(options.current_val.size()) + " samples, the records " +
                                  std::to_string(u_est.size()) + " + " + std::to_string(u_val.size()));
    if (!options.current_est.allFinite() || !options.current_val.allFinite())
      throw std::invalid_argument("diagnose: a sample of the current is not finite");
    if (!(options.current_est.cwiseAbs().maxCoeff() > 0.0))
      throw std::invalid_argument("diagnose: the current of the estimation record is zero throughout");
  }
}

// With the current: the force channel, its path identified as the baseline is (OE, lowest validation J over
// orders up to the drive's scan: the path from the current lacks the converters and the electrical pole).
std::optional<ForceChannel> force_channel_of(const Records& r, const DiagnosisOptions& options, Diagnosis& d) {
  if (options.current_est.size() == 0) return std::nullopt;
  if (options.progress) options.progress("identifying the force channel: the output from the current (OE)");
  DiagnosisOptions scan = options;
  scan.scan_from = std::max(2, options.scan_from - 6);
  scan.scan_to = std::max(scan.scan_from, options.scan_to - 2);
  const auto fitted = best_linear(options.current_est, r.y_est, options.current_val, r.y_val, r.fs, scan);
  ForceChannel c = diagnosis_detail::force_channel(r, fitted.first, options.current_est, options.current_val);
  d.channels.push_back("current");
  d.current_channel = {{"path", {{"method", "oe"}, {"na", c.path.tf.na()}, {"nb", c.path.tf.nb()}, {"nk", c.path.tf.nk}}},
                       {"J_val_pct", c.j_val_pct},
                       {"scan", fitted.second},
                       {"rule", "look-alike effects are told apart by their force features on the output explained from "
                                "the current (BIC on its validation residual)"}};
  return c;
}

// The candidates of a round whose validation test is run, best BIC first, before the round gives up.
constexpr std::size_t kTestedAtMost = 8;

// The rounds of a diagnosis from the baseline r.base: locate, score the candidates, keep the best while
// its BIC score is positive.
void run_rounds(const Records& r, const DiagnosisOptions& options, Diagnosis& d) {
  const auto progress = [&](const std::string& stage) {
    if (options.progress) options.progress(stage);
  };
  const Eigen::VectorXd &u_est = r.u_est, &y_est = r.y_est, &u_val = r.u_val, &y_val = r.y_val;
  const double fs = r.fs;
  progress("locating the residual of the baseline");
  Fit current = fit_terms(r, r.base->linear, {});
  d.baseline_model = current.model;
  d.baseline_j_val_pct = current.j_val;
  d.baseline_j_est_pct = current.j_est;
  d.j_val_before_pct = current.j_val;
  d.located_est = locate_residual(u_est, y_est, simulate_augmented(current.model, u_est, y_est, r.init), fs, r.init);
  d.located_val = locate_residual(u_val, y_val, simulate_augmented(current.model, u_val, y_val, r.init), fs, r.init);
  const double n_val = static_cast<double>(u_val.size() - r.init);
  if (!diagnosis_detail::periodic_noise_floor(u_val, y_val, r.init)) progress("fitting every candidate term at once (what no candidate explains)");
  double no_candidate_pct = 0.0;
  const diagnosis_detail::NoiseFloor floor = diagnosis_detail::diagnosis_noise_floor(r, current, d.located_val, no_candidate_pct);
  d.noise_floor_pct = floor.pct;
  d.noise_floor = diagnosis_detail::noise_floor_to_json(floor, d.located_val.noise_floor_pct, no_candidate_pct);
  const std::optional<ForceChannel> force = force_channel_of(r, options, d);
  std::vector<Effect> kept;
  const Eigen::Index judged = u_val.size() - r.init;
  const auto residual = [&](const AugmentedModel& m) -> Eigen::VectorXd {
    return (y_val - simulate_augmented(m, u_val, y_val, r.init)).tail(judged);
  };
  const auto judge_at_levels = [&](Finding& f, const AugmentedModel& before, const AugmentedModel& after) {
    diagnosis_detail::judge_at_levels(f, before, after, {options.level_name, u_val, y_val}, options.other_levels, r.init);
  };
  // Where the main resonance moves over the levels (computed once, when a spring and a damping look alike).
  std::optional<diagnosis_detail::ResonanceShift> level_shift;
  std::vector<diagnosis_detail::EarnedAlone> earned_before;  // the last round's earners, and the findings before it
  std::size_t findings_before = 0;
  d.stop = nullptr;
  for (int round = 0; round < options.max_findings; ++round) {
    // Nothing is looked for where J lies below the noise floor by more than the floor's uncertainty: nothing above
    // the noise is left to name (a floor lifted by distortion in the top band included). Within the uncertainty a
    // finding is made as elsewhere, and says so: concealed effects lie there (stopping at J ≤ floor cost the first
    // family's concealed cubic spring and creep one seed of three each, at floor + σ its resonance two).
    const double floor_low = floor.pct * (1.0 - diagnosis_detail::kFloorUncertainties * floor.relative_sd);
    const double floor_reach = floor.pct * (1.0 + diagnosis_detail::kFloorUncertainties * floor.relative_sd);
    const bool near_floor = current.j_val <= floor_reach;
    if (current.j_val <= floor_low) {
      d.stop = {{"round", round + 1},
                {"reason", "validation J " + fixed(current.j_val, 4) + " % lies below the noise floor (" + fixed(floor.pct, 4) +
                               " %, from " + to_string(floor.source) + ") by more than its uncertainty (" +
                               fixed(100.0 * floor.relative_sd, 1) + " %): nothing above the noise is left to name"}};
      break;
    }
    progress("round " + std::to_string(round + 1) + ": scoring candidate effects");
    const ResidualLocation where_est =
        locate_residual(u_est, y_est, simulate_augmented(current.model, u_est, y_est, r.init), fs, r.init);
    const ResidualLocation where_val =
        locate_residual(u_val, y_val, simulate_augmented(current.model, u_val, y_val, r.init), fs, r.init);
    int tried = 0;
    std::vector<Candidate> scored = candidates(r, current, where_est, options.oe_iterations, &tried);
    // BIC on the validation residual: N·ln(J_before/J_after) − p·ln(N) > 0 to be kept.
    const Candidate* chosen = nullptr;
    double best_score = 0.0;
    std::vector<std::pair<double, const Candidate*>> earning;  // BIC score > 0
    nlohmann::json round_json = nlohmann::json::array();
    // Periodic data weigh in: several periods of an odd multisine tell odd from even distortion in the
    // residual, and a candidate of the parity the residual lacks is not offered. Nor is a mode whose pair only
    // retunes a resonance the baseline already has.
    std::erase_if(scored, [&](const Candidate& c) {
      std::string why = ruled_out_by_periodic_distortion(c, where_val.distortion);
      if (why.empty()) why = diagnosis_detail::ruled_out_as_extra_mode(c);
      if (!why.empty())
        round_json.push_back({{"effect", to_string(c.effect)}, {"variant", c.variant}, {"J_val_pct", c.fit.j_val}, {"ruled_out", why}});
      return !why.empty();
    });
    // A candidate's BIC score against the model so far (read when called: `current` as it is then).
    const auto round_score = [&](const Candidate& c) { return diagnosis_detail::bic_score(current.j_val, c.fit.j_val, c.parameters, n_val); };
    for (const auto& c : scored) {
      const double score = round_score(c);
      round_json.push_back({{"effect", to_string(c.effect)}, {"variant", c.variant}, {"parameters", c.parameters},
                            {"J_val_pct", c.fit.j_val}, {"score", score}});
      // A linear refit's evidence (where the pair sits and what the refit changed), and a static nonlinearity's
      // placement (the pole groups before and after it), go with its score.
      if (c.parameters_json.contains("J_val_same_structure_refit_pct") || c.parameters_json.contains("front_poles"))
        round_json.back()["details"] = c.parameters_json;
      if (score > 0.0) earning.emplace_back(score, &c);
    }
    d.rounds.push_back(round_json);
    // What earned alone in the last finding's round and earns nothing beside it now: its term took that in.
    if (d.findings.size() > findings_before) diagnosis_detail::note_not_excluded(d.findings.back(), earned_before, scored, round_score, kept);
    findings_before = d.findings.size();
    earned_before.clear();
    for (const auto& [score, c] : earning) earned_before.push_back({c->effect, score});
    if (earning.empty()) {
      // With the current, a first force the drive's candidates are too small to earn may still show on the output
      // explained from the current (Rms(v) and friction together, whose nonlinear parts partly cancel in the drive's
      // residual): it is found there, with a second force beside it if the channel shows one.
      if (force && d.findings.empty()) {
        if (auto lead = diagnosis_detail::force_lead(*force, r, current, scored, kept)) {
          const Fit before = current;
          Finding f = diagnosis_detail::partner_finding(r, *lead, nullptr, current, where_est, d.noise_floor_pct);
          judge_at_levels(f, before.model, current.model);
          progress("found " + to_string(f.effect) + " (the force channel)");
          d.findings.push_back(std::move(f));
          if (auto partner = diagnosis_detail::force_partner(*force, r, before, *lead->candidate, scored, kept)) {
            kept.push_back(lead->candidate->effect);
            const Fit with_lead = current;
            Finding g = diagnosis_detail::partner_finding(r, *partner, lead->candidate, current, where_est, d.noise_floor_pct);
            judge_at_levels(g, with_lead.model, current.model);
            progress("found " + to_string(g.effect) + " beside it (the force channel)");
            kept.push_back(g.effect);
            d.findings.push_back(std::move(g));
          } else {
            kept.push_back(lead->candidate->effect);
          }
          continue;
        }
      }
      // No force alone earns there, two together may (their nonlinear parts cancel in part alone): looked for in the
      // first round, or after findings that are no force (a small linear refit, a delay, can earn first on the drive).
      if (force && std::ranges::none_of(kept, diagnosis_detail::acts_as_force)) {
        if (auto pair = diagnosis_detail::force_pair_lead(*force, r, current, scored, kept)) {
          for (const diagnosis_detail::ForcePartner* p : {&pair->lead, &pair->partner}) {
            const Fit before = current;
            Finding f = diagnosis_detail::partner_finding(r, *p, p == &pair->lead ? nullptr : pair->lead.candidate, current,
                                                          where_est, d.noise_floor_pct);
            const diagnosis_detail::ForcePartner& other = p == &pair->lead ? pair->partner : pair->lead;
            f.explanation += " Its force and " + to_string(other.candidate->effect) + "'s together earn BIC " +
                             fixed(pair->joint_score, 1) + " on the output explained from the current.";
            f.evidence["force_channel"]["pair_joint_bic"] = pair->joint_score;
            f.evidence["force_channel"]["pairs_tried"] = pair->pairs_tried;
            judge_at_levels(f, before.model, current.model);
            progress("found " + to_string(f.effect) + " (the force channel, jointly)");
            kept.push_back(f.effect);
            d.findings.push_back(std::move(f));
          }
          continue;
        }
      }
      d.stop = {{"round", round + 1}, {"reason", "no candidate earns its parameters (BIC on the validation samples)"}};
      break;
    }
    // A later finding: of those that earn their parameters (best BIC first), the first that also removes more of
    // the validation residual than noise lets any of the candidates tried remove: its gain in squared error, made
    // consistently over the record (the signed ranks of batch means), beyond a threshold shared over them. A gain
    // made in some stretches and lost in others (a linear change standing in for a spring at one level) does not
    // pass, and the next is tested. The first finding, beyond the floor's uncertainty, is the best BIC (its test is
    // reported): on a coloured residual the test misses concealed effects that the BIC names right.
    std::ranges::sort(earning, [](const auto& a, const auto& b) { return a.first > b.first; });
    std::optional<diagnosis_detail::ValidationGain> passed;
    nlohmann::json failed = nlohmann::json::array();
    const Eigen::VectorXd before = residual(current.model);
    for (const auto& [score, c] : earning) {
      const diagnosis_detail::ValidationGain g = diagnosis_detail::validation_gain(before, residual(c->fit.model), tried);
      if (g.significant || d.findings.empty()) {
        passed = g, chosen = c, best_score = score;
        break;
      }
      failed.push_back({{"effect", to_string(c->effect)}, {"variant", c->variant}, {"score", score}, {"z", g.z}, {"threshold", g.threshold}});
      if (failed.size() >= kTestedAtMost) break;
    }
    if (!passed) {
      d.stop = {{"round", round + 1},
                {"reason", std::string(near_floor ? "validation J " + fixed(current.j_val, 4) + " % lies within the noise floor's uncertainty (" +
                                                       fixed(floor.pct, 4) + " % + " + fixed(100.0 * floor.relative_sd, 1) + " %, from " +
                                                       to_string(floor.source) + "); "
                                                 : "") +
                               std::to_string(failed.size()) + " candidate(s) earn their parameters, the best " + to_string(earning.front().second->effect) +
                               ", but none's validation gain passes what noise lets one of the " + std::to_string(tried) +
                               " candidates tried reach (z " + fixed(failed.front()["z"].get<double>(), 2) + " against " +
                               fixed(failed.front()["threshold"].get<double>(), 2) + ")"},
                {"failed_tests", failed}};
      break;
    }
    const diagnosis_detail::ValidationGain test = *passed;
    // Two effects at once: a pair of the leading terms fitted jointly, kept when it beats the best alone and each
    // of its terms earns its place beside the other.
    if (auto pair = diagnosis_detail::best_joint_pair(r, current, scored, best_score, n_val, residual)) {
      std::vector<Finding> found = diagnosis_detail::pair_findings(r, *pair, current, where_val.effective_samples, where_est, force.has_value());
      const Candidate* alone = found.front().effect == pair->first->effect ? pair->first : pair->second;
      judge_at_levels(found[0], current.model, alone->fit.model);
      judge_at_levels(found[1], alone->fit.model, pair->fit.model);
      for (Finding& f : found) {
        const double excess = f.j_val_before_pct - d.noise_floor_pct;
        f.confidence["explained_share"] = excess > 0.0 ? std::min(1.0, (f.j_val_before_pct - f.j_val_after_pct) / excess) : 1.0;
        progress("found " + to_string(f.effect) + " (jointly): validation J " + fixed(f.j_val_before_pct, 3) + " % → " +
                 fixed(f.j_val_after_pct, 3) + " %");
        kept.push_back(f.effect);
        d.findings.push_back(std::move(f));
      }
      d.rounds.back().push_back({{"pair", {to_string(pair->first->effect), to_string(pair->second->effect)}},
                                 {"J_val_pct", pair->fit.j_val}, {"parameters", pair->parameters}, {"pairs_tried", pair->tried}});
      current = pair->fit;
      continue;
    }
    // Effects that look alike from the drive: the current decides between them; without it they are reported
    // as ambiguous, not named.
    // With the current every look-alike of a look-alike joins the force channel's verdict (a force factor's Rms(v)
    // brings in the cubic spring Rms(v) looks like: a cubic spring and a Bl(x²) came out as Rms(v), clear).
    const std::vector<const Candidate*> alikes = look_alikes_of(*chosen, scored, round_score, force.has_value());
    std::optional<diagnosis_detail::FindingConfidence> alike_confidence;
    nlohmann::json current_verdict;
    // The drive's own margin over the best look-alike, on the validation residual's effective samples (as
    // judge_finding counts them): a clear one settles the name without the current (Silverbox's spring, far
    // ahead of a damping).
    const double n_eff = std::max(where_val.effective_samples, 2.0);
    const auto bic_eff = [&](const Candidate& c) {
      return n_eff * std::log(current.j_val / c.fit.j_val) - c.parameters * std::log(n_eff);
    };
    const Candidate* rival = alikes.empty() ? nullptr : alikes.front();
    for (const Candidate* a : alikes)
      if (bic_eff(*a) > bic_eff(*rival)) rival = a;
    // The current tells apart forces of the motion; a linear look-alike pair (creep and a mode) its path absorbs.
    const bool force_pair =
        rival != nullptr && (diagnosis_detail::acts_as_force(chosen->effect) || diagnosis_detail::acts_as_force(rival->effect));
    const double drive_margin = rival != nullptr ? bic_eff(*chosen) - bic_eff(*rival) : 0.0;
    // Rms(v) and a coil offset have no drive signature of their own (near one resonance v³ is x³ with a phase, x·u
    // is x² times the drive): from the drive alone they are never named over a look-alike that earns.
    const bool needs_current = chosen->effect == Effect::nonlinear_damping || chosen->effect == Effect::asymmetric_force_factor;
    // Nor is creep over a mode, or a mode over creep, when both earn: each is a change of the same linear dynamics,
    // and the mode's refit (every coefficient moved) fits concealed creep better than creep's own term does.
    const bool drive_settles =
        rival == nullptr || (!needs_current && force_pair && drive_margin >= diagnosis_detail::kClearMargin);
    // Without the current, records at several levels tell a spring from a damping that look alike from the drive:
    // a stiffness that changes with the level moves the main resonance in frequency, a damping in decay rate.
    std::optional<diagnosis_detail::ResonanceShift> shift;
    if (!force && rival != nullptr && !drive_settles && !options.other_levels.empty() &&
        diagnosis_detail::spring_or_damping(chosen->effect, rival->effect)) {
      if (!level_shift) {
        progress("identifying the main resonance at each level (a spring moves it in frequency, a damping in decay)");
        level_shift = diagnosis_detail::resonance_shift(current.model.linear, {options.level_name, u_val, y_val}, options.other_levels, r.init);
      }
      shift = level_shift;
    }
    if (rival != nullptr && force && force_pair) {
      diagnosis_detail::FindingConfidence c;
      const Candidate* pick = decided_by_current(chosen, alikes, *force, r, current, kept, current_verdict, c);
      if (!drive_settles) {
        chosen = pick;  // the drive cannot tell them apart: the current decides
        alike_confidence = c;
      } else if (pick != chosen) {
        // The drive clearly says one, the current another: what the data cannot settle is not named.
        c.word = "ambiguous";
        c.runner_up = to_string(pick->effect);
        c.runner_up_variant = pick->variant;
        c.margin_bic = 0.0;
        c.sentence = "ambiguous between " + to_string(chosen->effect) + " and " + c.runner_up + ": the drive favours " +
                     to_string(chosen->effect) + " (BIC margin " + fixed(drive_margin, 1) +
                     "), the output explained from the current " + c.runner_up + ".";
        alike_confidence = c;
      }
    } else if (rival != nullptr && !drive_settles) {
      // Without the current the margin that the data cannot settle is reported, not a name; of a new force that
      // needs the current and its established look-alike, the look-alike's term is the one applied.
      if (needs_current && !(rival->effect == Effect::nonlinear_damping || rival->effect == Effect::asymmetric_force_factor))
        std::swap(chosen, rival);
      diagnosis_detail::FindingConfidence c;
      c.word = "ambiguous";
      c.runner_up = to_string(rival->effect);
      c.runner_up_variant = rival->variant;
      c.margin_bic = drive_margin;
      c.sentence = "ambiguous between " + to_string(chosen->effect) + " and " + c.runner_up +
                   ": they look alike from the drive (BIC margin " + fixed(c.margin_bic, 1) + "); " +
                   (force_pair ? "a record with the coil current tells them apart."
                               : "both are linear: a creeping suspension shows far below the resonance, where an "
                                 "accelerometer sees little; a displacement sensor or more drive there tells them apart.");
      if (shift) diagnosis_detail::name_by_resonance_shift(*shift, chosen, rival, drive_margin, c);
      alike_confidence = c;
    }
    const double correlation = added_correlation(r, current, chosen->fit);
    Finding f;
    f.effect = chosen->effect;
    f.added_parameters = chosen->parameters;
    f.j_val_before_pct = current.j_val;
    f.j_val_after_pct = chosen->fit.j_val;
    f.explanation = explain(*chosen, where_est, correlation);
    f.evidence = {{"score_bic", best_score},
                  {"added_correlation", correlation},
                  {"J_est_before_pct", current.j_est},
                  {"J_est_after_pct", chosen->fit.j_est},
                  {"residual_estimation", location_to_json(where_est)},
                  {"residual_validation", location_to_json(where_val)},
                  {"validation_test", diagnosis_detail::validation_gain_to_json(test)},
                  {"within_noise_floor_uncertainty", near_floor}};
    diagnosis_detail::FindingConfidence confidence =
        judge_finding(*chosen, scored, current.j_val, where_val.effective_samples, d.noise_floor_pct);
    if (alike_confidence) {
      const double share = confidence.explained_share;
      confidence = *alike_confidence;
      confidence.explained_share = share;
      confidence.sentence += " It explains " + fixed(100.0 * share, 0) + " % of J above the noise floor.";
    }
    // With the current, a coil offset after an asymmetric spring is as often the spring's own force in another shape
    // (x·i beside x² earns 108–254 on the force channel of a concealed spring alone) as a second effect: never clear.
    if (force && chosen->effect == Effect::asymmetric_force_factor && confidence.word != "ambiguous" &&
        std::ranges::find(kept, Effect::asymmetric_stiffness) != kept.end()) {
      confidence.word = "ambiguous";
      confidence.runner_up = to_string(Effect::asymmetric_stiffness);
      confidence.runner_up_variant.clear();
      confidence.sentence = "ambiguous between asymmetric_force_factor and more of asymmetric_stiffness: beside the spring's x², a "
                            "coil offset's x·i also fits what the spring's own force leaves (alone the verdict was \"" + confidence.sentence + "\").";
    }
    f.confidence = confidence_to_json(confidence);
    judge_at_levels(f, current.model, chosen->fit.model);
    if (!current_verdict.is_null()) f.evidence["current_channel"] = current_verdict;
    if (shift) f.evidence["resonance_shift"] = diagnosis_detail::resonance_shift_to_json(*shift);
    if (!failed.empty()) f.evidence["failed_tests_before"] = failed;  // better BIC, but their gains did not pass
    f.parameters = chosen->parameters_json;
    f.parameters["added"] = chosen->parameters;
    f.parameters["terms"] = terms_json(chosen->fit.model);
    progress("found " + to_string(f.effect) + ": validation J " + fixed(f.j_val_before_pct, 3) + " % → " +
             fixed(f.j_val_after_pct, 3) + " %");
    d.findings.push_back(std::move(f));
    // Two effects at once, with the current: a second force the force channel shows beside this one.
    std::optional<diagnosis_detail::ForcePartner> partner;
    if (force) partner = diagnosis_detail::force_partner(*force, r, current, *chosen, scored, kept);
    kept.push_back(chosen->effect);
    current = chosen->fit;
    if (partner) {
      Finding g = diagnosis_detail::partner_finding(r, *partner, chosen, current, where_est, d.noise_floor_pct);
      judge_at_levels(g, chosen->fit.model, current.model);
      progress("found " + to_string(g.effect) + " beside " + to_string(chosen->effect) + " (the force channel)");
      kept.push_back(g.effect);
      d.findings.push_back(std::move(g));
    }
  }

  d.j_val_after_pct = current.j_val;
  d.at_noise_floor = at_noise_floor(d.j_val_after_pct, d.noise_floor_pct);
  d.located_val_after = locate_residual(u_val, y_val, simulate_augmented(current.model, u_val, y_val, r.init), fs, r.init);
  d.model = current.model;
  d.unexplained = unexplained_residual(d.j_val_after_pct, d.noise_floor_pct, d.located_val_after);
}

// `simulate` with its results kept per record (input and output data, length, init): a diagnosis simulates
// the same two records for every candidate, and a plant simulation is costly.
RecordSimulation remembered(RecordSimulation simulate) {
  struct Entry {
    const double* u;
    const double* y;
    Eigen::Index size, init;
    double u_sum;
    Eigen::VectorXd output;
  };
  auto entries = std::make_shared<std::vector<Entry>>();
  return [simulate = std::move(simulate), entries](const Eigen::VectorXd& u, const Eigen::VectorXd& y, Eigen::Index init) {
    const double sum = u.sum();
    for (const Entry& e : *entries)
      if (e.u == u.data() && e.y == y.data() && e.size == u.size() && e.init == init && e.u_sum == sum) return e.output;
    Eigen::VectorXd output = simulate(u, y, init);
    if (output.size() != u.size() || !output.allFinite())
      throw std::invalid_argument("diagnose: the baseline's simulation of " + std::to_string(u.size()) +
                                  " samples is not finite or not as long as its input");
    entries->push_back({u.data(), y.data(), u.size(), init, sum, output});
    return output;
  };
}

}  // namespace

Diagnosis diagnose(const Eigen::VectorXd& u_est, const Eigen::VectorXd& y_est, const Eigen::VectorXd& u_val,
                   const Eigen::VectorXd& y_val, double fs, const std::optional<LinearModel>& baseline,
                   const DiagnosisOptions& options) {
  check_arguments(u_est, y_est, u_val, y_val, fs, options);
  Records r{u_est, y_est, u_val, y_val, fs, options.init, options.lags};
  r.output = options.output;
  Diagnosis d;
  d.output_quantity = options.output;
  LinearModel linear;
  if (baseline) {
    linear = *baseline;
    if (std::abs(linear.fs - fs) > 1e-6 * fs)
      throw std::invalid_argument("diagnose: the model was identified at " + std::to_string(linear.fs) +
                                  " Hz but the data is at " + std::to_string(fs) + " Hz");
    d.baseline_info = {{"source", "given"}, {"method", linear.method}, {"na", linear.tf.na()}, {"nb", linear.tf.nb()}, {"nk", linear.tf.nk}};
  } else {
    if (options.progress)
      options.progress("identifying the best linear model (OE, orders " + std::to_string(options.scan_from) + ".." +
                       std::to_string(options.scan_to) + ")");
    nlohmann::json scan;
    std::tie(linear, scan) = best_linear(u_est, y_est, u_val, y_val, fs, options);
    // The delay estimated from the data is the first *visible* one; a converter's latency often leaves
    // a small first sample before it, so one sample less is tried too and kept if validation J says so.
    const int nk_estimated = linear.tf.nk;
    if (linear.tf.nk > 0 && linear.tf.nb() >= 2) {
      if (options.progress) options.progress("trying one sample less of delay than estimated");
      TransferFunction shorter = linear.tf;
      shorter.nk -= 1;
      shorter.b = Eigen::VectorXd::Zero(linear.tf.nb());
      shorter.b.tail(linear.tf.nb() - 1) = linear.tf.b.head(linear.tf.nb() - 1);
      if (auto m = refit_linear(r, linear, shorter, options.oe_iterations))
        if (simulation_j_percent(*m, u_val, y_val, r.init) < simulation_j_percent(linear, u_val, y_val, r.init)) linear = *m;
    }
    d.baseline_info = {{"source", "identified"}, {"method", "oe"}, {"na", linear.tf.na()}, {"nb", linear.tf.nb()},
                       {"nk", linear.tf.nk}, {"nk_estimated", nk_estimated},
                       {"order_rule", "lowest validation J over the scan, then nk or nk − 1 by validation J"}, {"scan", scan}};
  }
  AugmentedModel base;
  base.linear = linear;
  r.base = &base;
  run_rounds(r, options, d);
  return d;
}

Diagnosis diagnose(const Eigen::VectorXd& u_est, const Eigen::VectorXd& y_est, const Eigen::VectorXd& u_val,
                   const Eigen::VectorXd& y_val, double fs, const SimulationBaseline& baseline,
                   const DiagnosisOptions& options) {
  check_arguments(u_est, y_est, u_val, y_val, fs, options);
  if (!baseline.simulate) throw std::invalid_argument("diagnose: the " + baseline.kind + " baseline has no simulation");
  if (std::abs(baseline.fs - fs) > 1e-6 * fs)
    throw std::invalid_argument("diagnose: the " + baseline.kind + " baseline runs at " + std::to_string(baseline.fs) +
                                " Hz but the data is at " + std::to_string(fs) + " Hz");
  Records r{u_est, y_est, u_val, y_val, fs, options.init, options.lags};
  r.output = options.output;
  AugmentedModel base;
  base.simulate_baseline = remembered(baseline.simulate);
  if (options.progress) options.progress("simulating the " + baseline.kind + " baseline and fitting its linearisation (OE)");
  const Eigen::VectorXd b_est = base.simulate_baseline(u_est, y_est, options.init);
  const Eigen::VectorXd b_val = base.simulate_baseline(u_val, y_val, options.init);
  // A noise-free output lets high orders fit it exactly (rank-deficient least squares): a dither ~90 dB
  // below it (fixed seeds) keeps the order scan well posed without changing the fit.
  auto dithered = [](const Eigen::VectorXd& y, std::uint64_t seed) -> Eigen::VectorXd {
    const double rms = std::sqrt(y.squaredNorm() / static_cast<double>(std::max<Eigen::Index>(1, y.size())));
    return y + dsp::gaussian_noise(static_cast<std::size_t>(y.size()), 1e-4 * std::max(rms, 1e-300), seed);
  };
  auto [linear, scan] = best_linear(u_est, dithered(b_est, 1), u_val, dithered(b_val, 2), fs, options);
  base.linear = linear;
  base.reference = linear;
  r.base = &base;
  Diagnosis d;
  d.output_quantity = options.output;
  d.baseline_kind = baseline.kind;
  d.baseline_info = {{"source", "given"},
                     {"linearisation",
                      {{"method", "oe"}, {"na", linear.tf.na()}, {"nb", linear.tf.nb()}, {"nk", linear.tf.nk},
                       {"J_val_pct_of_the_baseline_output", simulation_j_percent(linear, u_val, b_val, options.init)},
                       {"scan", scan}}}};
  run_rounds(r, options, d);
  return d;
}

std::string to_string(OutputQuantity quantity) {
  switch (quantity) {
    case OutputQuantity::unknown: return "unknown";
    case OutputQuantity::displacement: return "displacement";
    case OutputQuantity::velocity: return "velocity";
    case OutputQuantity::acceleration: return "acceleration";
  }
  return "unknown";
}

std::vector<OutputQuantity> all_output_quantities() {
  return {OutputQuantity::unknown, OutputQuantity::displacement, OutputQuantity::velocity, OutputQuantity::acceleration};
}

bool at_noise_floor(double j_pct, double noise_floor_pct) {
  return noise_floor_pct > 0.0 && j_pct < kNoiseFloorMargin * noise_floor_pct;
}

nlohmann::json diagnosis_to_json(const Diagnosis& d) {
  nlohmann::json findings = nlohmann::json::array();
  for (const auto& f : d.findings)
    findings.push_back({{"effect", to_string(f.effect)},
                        {"explanation", f.explanation},
                        {"confidence", f.confidence},
                        {"evidence", f.evidence},
                        {"parameters", f.parameters},
                        {"J_val_before_pct", f.j_val_before_pct},
                        {"J_val_after_pct", f.j_val_after_pct}});
  nlohmann::json baseline = d.baseline_info;
  baseline["kind"] = d.baseline_kind;
  baseline["J_val_pct"] = d.baseline_j_val_pct;
  baseline["J_est_pct"] = d.baseline_j_est_pct;
  baseline["output_quantity"] = to_string(d.output_quantity);
  nlohmann::json channels = {{"used", d.channels}, {"current", d.current_channel}};
  return {{"baseline", baseline},
          {"channels", channels},
          {"findings", findings},
          {"J_val_before_pct", d.j_val_before_pct},
          {"J_val_after_pct", d.j_val_after_pct},
          {"noise_floor_pct", d.noise_floor_pct},
          {"noise_floor", d.noise_floor},
          {"at_noise_floor", d.at_noise_floor},
          {"stopped", d.stop},
          {"unexplained", d.unexplained},
          {"location",
           {{"estimation", location_to_json(d.located_est)},
            {"validation", location_to_json(d.located_val)},
            {"validation_after", location_to_json(d.located_val_after)}}},
          {"rounds", d.rounds},
          {"rule", "no augmentation is looked for while validation J lies below the noise floor by more than its uncertainty; the best "
                   "augmentation of a round is kept when N·ln(J_before/J_after) > p·ln(N) on the N validation samples (BIC, "
                   "p its added parameters, every earlier term refitted with it) and, after the first finding, its gain in "
                   "validation squared error passes a signed-rank test (batch means of the whitened residuals) at a family-wise level of 1 % shared over the candidates the round tried"}};
}

}  // namespace panelbass::models
