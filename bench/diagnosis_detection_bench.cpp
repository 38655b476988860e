// Detection rate of `diagnose` over many seeds and effect sizes (issue #9): for every effect of the
// vocabulary, its concealed scenario (tests/support/diagnosis_scenarios.h) at each size, diagnosed per seed;
// a detection is the right id as the first finding. The false-positive rate comes from the scenario
// with no effect. Prints a markdown table; every run is also one line on stderr.
//
//   build/bin/diagnosis_detection_bench --seeds 10 --sizes 0.5,1,2 [--effects cubic_stiffness,delay] [--plain 20]
//   build/bin/diagnosis_detection_bench --family second ...   (issue 58's second family; a confusion matrix at the end)
//   build/bin/diagnosis_detection_bench --resonance-shift --effects cubic_stiffness,nonlinear_damping --sizes 1,2 --seeds 3
//     (records at two levels: where the main resonance moves, no diagnosis)
#include <CLI/CLI.hpp>
#include <algorithm>
#include <cmath>
#include <cstdio>
#include <map>
#include <string>
#include <vector>

#include "dsp/spectrum.h"
#include "dsp/excitation.h"
#include "models/diagnosis/diagnosis.h"
#include "models/diagnosis/diagnosis_levels.h"
#include "models/linear/linear_identification.h"
#include "models/plant/virtual_transducer.h"
#include "tests/support/diagnosis_scenarios.h"

namespace {

using namespace panelbass::models;

constexpr Eigen::Index kInit = 50;
bool verbose = false;  // every round's candidates on stderr
bool with_current = false;  // the records carry the coil current (the force channel)
PlantFamily family = PlantFamily::panel;
// The confusion matrix: per true effect ("none", "none-microphone" for the effect-free records), how often each
// first finding (with its word) came first.
std::map<std::string, std::map<std::string, int>> confusion;
// The findings after the first, per true effect (a spurious "clear" after the truth is issue 58's complaint).
std::map<std::string, std::map<std::string, int>> later_findings;

Effect effect_named(const std::string& id) {
  for (Effect e : all_effects())
    if (to_string(e) == id) return e;
  throw CLI::ValidationError("--effects", "unknown effect id \"" + id + "\"");
}

struct Run {
  std::string first = "none";
  std::string word;  ///< the first finding's confidence: clear, likely or ambiguous
  std::string runner_up;  ///< the first finding's runner-up (of an ambiguous finding: the other name)
  int findings = 0;
  std::vector<std::string> names;  ///< every finding's effect, in order
  std::vector<std::string> words;  ///< every finding's word, of an ambiguous one the other name ("ambiguous: x"), and
                                   ///< the effects it does not exclude ("; not excluded: y")
  double concealment = 0.0, j_before = 0.0, j_after = 0.0;
  std::string baseline;
};

DiagnosisOptions options_for(const DiagnosisScenario& s) {
  DiagnosisOptions o;
  o.init = kInit;
  o.scan_from = family_order(s.family) - 1;  // the family's true order: a narrow scan keeps each run short
  o.scan_to = family_order(s.family);
  o.output = OutputQuantity::acceleration;  // the virtual transducer's sensor is an accelerometer
  o.max_findings = static_cast<int>(std::max<std::size_t>(1, s.effects.size())) + 1;
  return o;
}

Run run_once(const DiagnosisScenario& s, std::uint64_t seed, Eigen::Index n_est, Eigen::Index n_val) {
  const ScenarioRecords r = scenario_records(s, seed, n_est, n_val);
  DiagnosisOptions o = options_for(s);
  if (with_current) o.current_est = r.i_est, o.current_val = r.i_val;
  const Diagnosis d = diagnose(r.u_est, r.y_est, r.u_val, r.y_val, r.fs, scenario_baseline(s), o);
  Run run;
  run.findings = static_cast<int>(d.findings.size());
  for (const auto& f : d.findings) {
    run.names.push_back(to_string(f.effect));
    const nlohmann::json& other = f.confidence["runner_up"];
    const std::string word = f.confidence.value("word", "");
    std::string worded = word == "ambiguous" && other.is_string() ? word + ": " + other.get<std::string>() : word;
    if (f.confidence.contains("not_excluded"))
      for (const auto& e : f.confidence["not_excluded"]) worded += "; not excluded: " + e.get<std::string>();
    run.words.push_back(worded);
  }
  if (!d.findings.empty()) {
    run.first = to_string(d.findings.front().effect);
    run.word = d.findings.front().confidence.value("word", "");
    const nlohmann::json& rival = d.findings.front().confidence["runner_up"];
    if (rival.is_string()) run.runner_up = rival.get<std::string>();
  }
  run.concealment = concealment_ratio(r, d.baseline_model.linear, kInit);
  run.j_before = d.j_val_before_pct;
  run.j_after = d.j_val_after_pct;
  run.baseline = d.baseline_info.dump();
  ++confusion[s.name][run.first + (run.word.empty() ? "" : " (" + run.word + ")")];
  for (std::size_t k = 1; k < d.findings.size(); ++k)
    ++later_findings[s.name][to_string(d.findings[k].effect) + " (" + d.findings[k].confidence.value("word", "") + ")"];
  if (verbose)
    std::fprintf(stderr, "baseline's residual: spectral peak %.1f Hz (%.1f times the noise, threshold %.1f), FRF error %.1f Hz "
                         "(coherence %.3f, threshold %.3f)\n",
                 d.located_est.peak_frequency_hz, d.located_est.peak_over_noise, d.located_est.peak_threshold,
                 d.located_est.frf_error.frequency_hz, d.located_est.frf_error.coherence, d.located_est.frf_error.threshold);
  if (verbose)
    std::fprintf(stderr, "noise floor: %s; stopped: %s\n", d.noise_floor.dump().c_str(), d.stop.dump().c_str());
  if (verbose)
    for (const auto& f : d.findings)
      std::fprintf(stderr, "finding %s: validation test %s\n", to_string(f.effect).c_str(), f.evidence["validation_test"].dump().c_str());
  if (verbose && !d.findings.empty() && d.findings.front().parameters.contains("J_val_same_structure_refit_pct"))
    std::fprintf(stderr, "first finding's linear refit: J %.4f %%, its structure refitted alone: J %.4f %%\n",
                 d.findings.front().j_val_after_pct,
                 d.findings.front().parameters["J_val_same_structure_refit_pct"].get<double>());
  if (verbose)
    for (const auto& f : d.findings)
      std::fprintf(stderr, "finding %s (%s): %s\n", to_string(f.effect).c_str(), f.confidence.value("word", "").c_str(),
                   f.parameters.dump().c_str());
  if (verbose)
    for (const auto& round : d.rounds) {
      std::string line;
      for (const auto& c : round)
        if (c.contains("pair"))
          line += "  pair " + c["pair"][0].get<std::string>() + "+" + c["pair"][1].get<std::string>() + " J " +
                  std::to_string(c["J_val_pct"].get<double>()).substr(0, 6);
        else if (!c.contains("ruled_out"))
          line += "  " + c["effect"].get<std::string>() + " (" + c["variant"].get<std::string>() + ") J " +
                std::to_string(c["J_val_pct"].get<double>()).substr(0, 6) + " score " + std::to_string(static_cast<int>(c["score"].get<double>()));
      std::fprintf(stderr, "round:%s\n", line.c_str());
      for (const auto& c : round)
        if (c.contains("pair")) continue;
        else if (c.contains("details")) std::fprintf(stderr, "  %s: %s\n", c["effect"].get<std::string>().c_str(), c["details"].dump().c_str());
        else if (c.contains("ruled_out"))
          std::fprintf(stderr, "  %s ruled out: %s\n", c["effect"].get<std::string>().c_str(), c["ruled_out"].get<std::string>().c_str());
    }
  return run;
}

// The confusion matrix in long form (one row per true effect and first finding: a script merges several
// processes' rows), then as a matrix: true effects down, first findings across.
void print_confusion() {
  std::printf("\n## confusion (%s family): true effect -> first finding (word)\n\n| true effect | first finding | runs |\n|---|---|---:|\n",
              to_string(family).c_str());
  std::map<std::string, int> columns;
  for (const auto& [truth, row] : confusion)
    for (const auto& [first, count] : row) {
      std::printf("| %s | %s | %d |\n", truth.c_str(), first.c_str(), count);
      columns[first.substr(0, first.find(' '))] += count;
    }
  std::printf("\n## later findings (%s family): true effect -> a finding after the first (word)\n\n"
              "| true effect | later finding | runs |\n|---|---|---:|\n", to_string(family).c_str());
  for (const auto& [truth, row] : later_findings)
    for (const auto& [later, count] : row) std::printf("| %s | %s | %d |\n", truth.c_str(), later.c_str(), count);
  std::printf("\n| true \\ first |");
  for (const auto& [first, count] : columns) std::printf(" %s |", first.c_str());
  std::printf("\n|---|");
  for (std::size_t k = 0; k < columns.size(); ++k) std::printf("---:|");
  std::printf("\n");
  for (const auto& [truth, row] : confusion) {
    std::printf("| %s |", truth.c_str());
    for (const auto& [first, total] : columns) {
      int n = 0;
      for (const auto& [seen, count] : row)
        if (seen.substr(0, seen.find(' ')) == first) n += count;
      std::printf(" %s |", n == 0 ? "" : std::to_string(n).c_str());
    }
    std::printf("\n");
  }
}

// Each effect's own size against the sensor noise, without diagnosing (for choosing the second family's sizes):
// the largest ratio over a Welch spectrum's bins of the PSD of what the effect changes in the noise-free output
// (the scenario's record minus the same drive through the family's plant without it) to the noise's PSD.
void print_effect_sizes(const std::vector<Effect>& effects, const std::vector<double>& sizes, Eigen::Index n_est,
                        Eigen::Index n_val) {
  std::printf("| effect | size | largest PSD ratio of the effect's change to the noise (seed 1) |\n|---|---:|---:|\n");
  const panelbass::dsp::WelchSpec spec{512, 0.5, panelbass::dsp::Window::hann};
  for (Effect e : effects)
    for (double size : sizes) {
      const DiagnosisScenario s = concealed_scenario(e, size, family);
      DiagnosisScenario bare = s;
      bare.plant = family_base(family);
      const ScenarioRecords r = scenario_records(s, 1, n_est, n_val);
      const ScenarioRecords b = scenario_records(bare, 1, n_est, n_val);
      const panelbass::dsp::PowerSpectrum change = panelbass::dsp::welch_psd(r.y_val_clean - b.y_val_clean, r.fs, spec);
      const panelbass::dsp::PowerSpectrum noise = panelbass::dsp::welch_psd(r.y_val - r.y_val_clean, r.fs, spec);
      double worst = 0.0;
      for (Eigen::Index k = 0; k < change.psd.size(); ++k) worst = std::max(worst, change.psd[k] / noise.psd[k]);
      std::printf("| %s | %.2f | %.3g |\n", to_string(e).c_str(), size, worst);
      std::fflush(stdout);
    }
}

double median(std::vector<double> v) {
  if (v.empty()) return 0.0;
  std::sort(v.begin(), v.end());
  return v[v.size() / 2];
}

// Records at two levels (full and half drive, `n` samples each, the loud one's first half identifies the baseline):
// where the main resonance moves (diagnosis_levels.h), for each effect, size and seed; the verdicts' counts.
void print_resonance_shifts(const std::vector<Effect>& effects, const std::vector<double>& sizes, int seeds,
                            std::uint64_t first_seed, Eigen::Index n) {
  std::printf("| effect | size | frequency (a spring) | decay rises (Rms(v)) | decay falls (friction) | neither | median Δf Hz | "
              "median Δσ 1/s |\n|---|---:|---:|---:|---:|---:|---:|---:|\n");
  for (Effect e : effects)
    for (double size : sizes) {
      const DiagnosisScenario s = concealed_scenario(e, size, family);
      std::map<std::string, int> moves;
      std::vector<double> d_f, d_sigma;
      for (int k = 0; k < seeds; ++k) {
        const std::uint64_t seed = first_seed + static_cast<std::uint64_t>(k);
        std::vector<LevelRecord> levels;
        LinearModel baseline;
        for (const double level : {1.0, 0.5}) {
          const std::uint64_t record_seed = 10 * seed + (level < 1.0 ? 1 : 0);
          const Eigen::VectorXd u = level * panelbass::dsp::uniform_noise(static_cast<std::size_t>(2 * n), 1.0, record_seed);
          const Eigen::VectorXd y = simulate(s.plant, u, record_seed + 100).y;
          if (level == 1.0) {
            LinearIdentificationSpec spec;
            spec.method = LinearMethod::oe;
            spec.order = family_order(s.family);
            spec.fs = s.plant.fs;
            spec.init = kInit;
            baseline = identify_linear(u.head(n), y.head(n), u.tail(n), y.tail(n), spec).model;
          }
          levels.push_back({level == 1.0 ? "loud" : "quiet", u.tail(n), y.tail(n)});
        }
        const diagnosis_detail::ResonanceShift shift = diagnosis_detail::resonance_shift(baseline, levels, kInit);
        ++moves[shift.judged ? shift.moves : "not judged"];
        d_f.push_back(shift.d_omega / (2.0 * M_PI));
        d_sigma.push_back(shift.d_sigma);
        std::fprintf(stderr, "%s size %.2f seed %llu: %s — %s\n", s.name.c_str(), size, static_cast<unsigned long long>(seed),
                     shift.moves.c_str(), shift.sentence.c_str());
      }
      std::printf("| %s | %.2f | %d/%d | %d/%d | %d/%d | %d/%d | %.3f | %.2f |\n", s.name.c_str(), size, moves["frequency"], seeds,
                  moves["decay"], seeds, moves["decay_falls"], seeds, moves["neither"] + moves["not judged"], seeds, median(d_f),
                  median(d_sigma));
      std::fflush(stdout);
    }
}


}  // namespace

int main(int argc, char** argv) {
  CLI::App app{"Detection rate of panelbass diagnose over seeds and effect sizes (concealed scenarios)"};
  int seeds = 10, plain = 20;
  std::vector<double> sizes = {0.5, 1.0, 2.0};
  std::vector<std::string> effects;
  long n_est = 60000, n_val = 40000;
  std::uint64_t first_seed = 1;
  app.add_option("--seeds", seeds, "Seeds per effect and size (0: only the effect-free runs)")->check(CLI::Range(0, 10000))->capture_default_str();
  app.add_option("--first-seed", first_seed, "First seed")->capture_default_str();
  app.add_option("--sizes", sizes, "Effect sizes, multiples of the concealed size")->delimiter(',')->capture_default_str();
  app.add_option("--effects", effects, "Effect ids (default: the whole vocabulary)")->delimiter(',');
  app.add_option("--plain", plain, "Seeds of the scenario with no effect (false positives)")->check(CLI::Range(0, 10000))->capture_default_str();
  app.add_option("--n-est", n_est, "Estimation samples")->check(CLI::Range(2000L, 10000000L))->capture_default_str();
  app.add_option("--n-val", n_val, "Validation samples")->check(CLI::Range(2000L, 10000000L))->capture_default_str();
  app.add_flag("--verbose", verbose, "Every round's candidates and scores on stderr");
  app.add_flag("--current", with_current, "The records carry the coil current: diagnose uses the force channel");
  std::string family_name = "panel";
  bool concealment_only = false;
  std::vector<std::string> pairs;
  app.add_option("--pairs", pairs, "Pairs of effects at once, a+b (each at --pair-size; both must be found)")->delimiter(',');
  double pair_size = 1.0;
  app.add_option("--pair-size", pair_size, "Each effect's size in a pair, a multiple of its concealed size (where a pair's "
                                           "detection limit lies)")
      ->check(CLI::Range(0.01, 100.0))
      ->capture_default_str();
  app.add_option("--family", family_name, "The plants: panel (the linear preset) or second (issue 58's second family: "
                                          "tests/support/plants/second-exciter-linear.json)")
      ->check(CLI::IsMember({"panel", "second"}))
      ->capture_default_str();
  bool level_shift = false;
  app.add_flag("--resonance-shift", level_shift, "Records at two levels (full and half drive, --n-val samples each): where the "
                                                 "main resonance moves, a spring's frequency or a damping's decay (no diagnosis)");
  app.add_flag("--concealment-only", concealment_only, "Print each effect's own size against the sensor noise (largest PSD ratio); no diagnosis");
  app.footer("Example:\n  build/bin/diagnosis_detection_bench --seeds 5 --sizes 1,2 --effects cubic_stiffness,hysteresis --plain 5");
  CLI11_PARSE(app, argc, argv);

  std::vector<Effect> chosen;
  try {
    for (const auto& id : effects) chosen.push_back(effect_named(id));
  } catch (const CLI::Error& e) {
    return app.exit(e);
  }
  if (chosen.empty()) chosen = all_effects();
  family = plant_family_named(family_name);
  if (level_shift) {
    print_resonance_shifts(chosen, sizes, seeds, first_seed, n_val);
    return 0;
  }
  if (concealment_only) {
    print_effect_sizes(chosen, sizes, n_est, n_val);
    return 0;
  }

  std::printf("## diagnose detection rate (%ld + %ld samples, seeds %llu..%llu)\n\n", n_est, n_val,
              static_cast<unsigned long long>(first_seed), static_cast<unsigned long long>(first_seed + seeds - 1));
  std::printf("plants: the %s family; channels: drive, acceleration%s\n\n", to_string(family).c_str(),
              with_current ? ", current" : "");
  std::printf("| effect | size | detected first | right and clear | right, or ambiguous naming it | wrong and clear | wrong, not ambiguous | median concealment | median J before %% | median J after %% | first findings seen (word) |\n");
  std::printf("|---|---:|---:|---:|---:|---:|---:|---:|---:|---:|---|\n");
  int runs = 0, confidently_wrong = 0, wrong_named = 0, right_total = 0, right_or_ambiguous_total = 0;
  for (Effect e : chosen) {
    if (seeds == 0 || !pairs.empty()) break;
    for (double size : sizes) {
      const DiagnosisScenario s = concealed_scenario(e, size, family);
      int hits = 0, clear_hits = 0, wrong_clear = 0, wrong_not_ambiguous = 0, right_or_ambiguous = 0;
      std::vector<double> concealment, before, after;
      std::map<std::string, int> seen;
      for (int k = 0; k < seeds; ++k) {
        const std::uint64_t seed = first_seed + static_cast<std::uint64_t>(k);
        const Run run = run_once(s, seed, n_est, n_val);
        std::fprintf(stderr, "%s size %.2f seed %llu: first %s (%d findings), concealment %.2f, J %.4f -> %.4f %% %s\n",
                     s.name.c_str(), size, static_cast<unsigned long long>(seed), run.first.c_str(), run.findings,
                     run.concealment, run.j_before, run.j_after, run.baseline.c_str());
        hits += run.first == s.name;
        clear_hits += run.first == s.name && run.word == "clear";
        wrong_clear += run.first != s.name && run.first != "none" && run.word == "clear";
        wrong_not_ambiguous += run.first != s.name && run.first != "none" && run.word != "ambiguous";
        right_or_ambiguous += run.first == s.name || (run.word == "ambiguous" && run.runner_up.find(s.name) != std::string::npos);
        ++runs;
        concealment.push_back(run.concealment);
        before.push_back(run.j_before);
        after.push_back(run.j_after);
        ++seen[run.first + (run.word.empty() ? "" : " (" + run.word + ")")];
      }
      std::string firsts;
      for (const auto& [id, count] : seen) firsts += (firsts.empty() ? "" : ", ") + id + " " + std::to_string(count);
      confidently_wrong += wrong_clear;
      wrong_named += wrong_not_ambiguous;
      right_total += hits;
      right_or_ambiguous_total += right_or_ambiguous;
      std::printf("| %s | %.2f | %d/%d | %d/%d | %d/%d | %d/%d | %d/%d | %.2f | %.4f | %.4f | %s |\n", s.name.c_str(), size, hits,
                  seeds, clear_hits, seeds, right_or_ambiguous, seeds, wrong_clear, seeds, wrong_not_ambiguous, seeds,
                  median(concealment), median(before), median(after), firsts.c_str());
      std::fflush(stdout);
    }
  }
  std::printf("\nright first: %d/%d; right, or ambiguous naming the right one: %d/%d\n", right_total, runs,
              right_or_ambiguous_total, runs);
  std::printf("confidently wrong (a wrong first name called clear): %d/%d; a wrong name not called ambiguous: %d/%d\n",
              confidently_wrong, runs, wrong_named, runs);
  if (!pairs.empty()) {
    std::printf("\n| pair | both found | one found, the other only named beside it (ambiguous with it, or not excluded) | first is one of them | "
                "median concealment | findings seen |\n|---|---:|---:|---:|---:|---|\n");
    for (const std::string& pair : pairs) {
      const std::size_t plus = pair.find('+');
      if (plus == std::string::npos) {
        std::fprintf(stderr, "--pairs: \"%s\" is not a+b\n", pair.c_str());
        return 2;
      }
      Effect a{}, b{};
      try {
        a = effect_named(pair.substr(0, plus));
        b = effect_named(pair.substr(plus + 1));
      } catch (const CLI::Error& e) {
        return app.exit(e);
      }
      const DiagnosisScenario s = combined_scenario(concealed_scenario(a, pair_size, family), concealed_scenario(b, pair_size, family));
      int both = 0, first_in = 0, other_named = 0;
      std::map<std::string, int> seen;
      std::vector<double> concealment;
      for (int k = 0; k < seeds; ++k) {
        const std::uint64_t seed = first_seed + static_cast<std::uint64_t>(k);
        const Run run = run_once(s, seed, n_est, n_val);
        concealment.push_back(run.concealment);
        const auto found = [&](Effect e) {
          return std::find(run.names.begin(), run.names.end(), to_string(e)) != run.names.end();
        };
        both += found(a) && found(b);
        // Not found, but named: a finding of the one is called ambiguous with the other, or does not exclude it
        // beside it (the drive cannot tell them apart). Counted apart from "both found": it says one effect is
        // there and the other may be, not that both are.
        const auto named_beside = [&](Effect found_one, Effect other) {
          for (std::size_t j = 0; j < run.names.size(); ++j)
            if (run.names[j] == to_string(found_one) &&
                (run.words[j].find("ambiguous: " + to_string(other)) != std::string::npos ||
                 run.words[j].find("not excluded: " + to_string(other)) != std::string::npos))
              return true;
          return false;
        };
        other_named += !(found(a) && found(b)) && ((found(a) && named_beside(a, b)) || (found(b) && named_beside(b, a)));
        first_in += run.first == to_string(a) || run.first == to_string(b);
        std::string worded;
        for (std::size_t k = 0; k < run.names.size(); ++k)
          worded += (worded.empty() ? "" : " → ") + run.names[k] + " (" + run.words[k] + ")";
        ++seen[worded.empty() ? "none" : worded];
        std::fprintf(stderr, "%s seed %llu: %s (concealment %.2f, J %.4f -> %.4f %%)\n", s.name.c_str(),
                     static_cast<unsigned long long>(seed), worded.c_str(), run.concealment, run.j_before, run.j_after);
      }
      std::string firsts;
      for (const auto& [id, count] : seen) firsts += (firsts.empty() ? "" : ", ") + id + " " + std::to_string(count);
      std::printf("| %s | %d/%d | %d/%d | %d/%d | %.2f | %s |\n", s.name.c_str(), both, seeds, other_named, seeds, first_in, seeds,
                  median(concealment), firsts.c_str());
      std::fflush(stdout);
    }
  }
  if (plain > 0) {
    int false_positives = 0;
    std::map<std::string, int> seen;
    const std::vector<DiagnosisScenario> effect_free = effect_free_scenarios(family);
    for (int k = 0; k < plain; ++k) {
      const std::uint64_t seed = first_seed + 1000 + static_cast<std::uint64_t>(k);
      // The family's effect-free scenarios in turn (the second family's: accelerometer, then microphone).
      const DiagnosisScenario& s = effect_free[static_cast<std::size_t>(k) % effect_free.size()];
      const Run run = run_once(s, seed, n_est, n_val);
      std::fprintf(stderr, "%s seed %llu: first %s, J %.4f -> %.4f %%\n", s.name.c_str(), static_cast<unsigned long long>(seed),
                   run.first.c_str(), run.j_before, run.j_after);
      if (run.findings > 0) ++false_positives, ++seen[run.first];
    }
    std::string firsts;
    for (const auto& [id, count] : seen) firsts += (firsts.empty() ? "" : ", ") + id + " " + std::to_string(count);
    std::printf("\nfalse positives (no effect, seeds %llu..%llu): %d/%d%s%s\n",
                static_cast<unsigned long long>(first_seed + 1000),
                static_cast<unsigned long long>(first_seed + 1000 + plain - 1), false_positives, plain,
                firsts.empty() ? "" : " — ", firsts.c_str());
  }
  print_confusion();
  return 0;
}
