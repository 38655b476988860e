#include <cmath>
#include <memory>
#include <optional>
#include <stdexcept>
#include <string>
#include <tuple>
#include <vector>

#include "cli/band_pass_option.h"
#include "cli/commands.h"
#include "cli/json_output.h"
#include "cli/progress_bar.h"
#include "dsp/sample_rate.h"
#include "models/control/feedback_design.h"
#include "models/io/json_file.h"
#include "models/kinds/model_file.h"
#include "models/plant/plant_presets.h"

namespace panelbass::cli {
namespace {

struct DesignNnOptions {
  std::string plant, ff, out;
  std::string tune_on;     // a device to tune on: a plant preset or file (empty: the plant model alone)
  std::string start_from;  // a controller to train on from (empty: fresh initial weights)
  std::string bandpass = "20,1200";
  int order = 2;
  models::FeedbackDesignOptions design;
};

nlohmann::json history_json(const std::vector<models::FeedbackTrainingRecord>& history) {
  nlohmann::json h = nlohmann::json::array();
  for (const auto& r : history) {
    h.push_back({{"iteration", r.iteration},
                 {"jc_est_pct", r.jc_est_pct},
                 {"jc_val_pct", std::isfinite(r.jc_val_pct) ? nlohmann::json(r.jc_val_pct) : nlohmann::json()},
                 {"rail_fraction", r.rail_fraction}});
  }
  return h;
}

void run_design_nn(DesignNnOptions o) {
  const models::AnyModel any = models::load_model(o.plant);
  std::optional<models::LoopPlant> plant;
  if (const auto* narx = std::get_if<models::NarxModel>(&any.model)) plant = *narx;
  if (const auto* ss = std::get_if<models::SsModel>(&any.model)) plant = *ss;
  if (!plant) {
    throw std::invalid_argument("--plant " + o.plant + ": expected a NARX or state-space (ss) model, got " + any.kind());
  }
  const models::LqFeedforward ff = models::lq_feedforward_from_json(models::read_json_file(o.ff));
  const std::vector<dsp::Biquad> band_pass = band_pass_sections(o.bandpass, o.order, ff.fs);
  ProgressBar bar("design nn");
  o.design.training.progress = [&](const models::FeedbackTrainingRecord& r) {
    bar.update((r.restart + static_cast<double>(r.iteration) / o.design.training.max_iterations) / o.design.restarts);
  };
  std::optional<models::PlantConfig> device;
  if (!o.tune_on.empty()) device = models::plant_from_name_or_file(o.tune_on);
  std::optional<models::NeuralFeedback> start;
  if (!o.start_from.empty()) {
    start = models::neural_feedback_from_json(models::read_json_file(o.start_from));
    if (!dsp::same_rate(start->fs, ff.fs)) {
      throw std::invalid_argument("--start-from " + o.start_from + ": designed at another rate than the feedforward's");
    }
    o.design.structure = start->structure;  // the meta says what the controller is
  }
  models::FeedbackDesign d =
      models::design_feedback(*plant, ff, band_pass, o.design, device ? &*device : nullptr, start ? &*start : nullptr);
  d.controller.meta = {{"plant", o.plant},
                       {"plant_kind", plant->kind()},
                       {"feedforward", o.ff},
                       {"bandpass", o.bandpass},
                       {"order", o.order},
                       {"tuned_on", o.tune_on.empty() ? nlohmann::json() : nlohmann::json(o.tune_on)},
                       {"start_from", o.start_from.empty() ? nlohmann::json() : nlohmann::json(o.start_from)},
                       {"restart", d.chosen_restart},
                       {"restart_jc_val_pct", d.restart_jc_val_pct},
                       {"restart_probe_change_db", d.restart_probe_change_db},
                       {"training", history_json(d.training.history)}};
  d.controller.meta.update(models::feedback_design_options_json(o.design));
  models::write_json_file(o.out, models::neural_feedback_to_json(d.controller));
  const models::FeedbackTrainingRecord& first = d.training.history.front();
  print_result({{"out", o.out},
                {"parameters", d.controller.net.parameter_count()},
                {"iterations", d.training.iterations},
                {"jc_val_before_pct", first.jc_val_pct},
                {"jc_val_after_pct", models::best_validation_jc_pct(d.training)},
                {"restart_jc_val_pct", d.restart_jc_val_pct},
                {"restart_probe_change_db", d.restart_probe_change_db},
                {"chosen_restart", d.chosen_restart},
                {"history", history_json(d.training.history)}});
}

}  // namespace

void add_design_nn(CLI::App& design) {
  auto o = std::make_shared<DesignNnOptions>();
  CLI::App* cmd = design.add_subcommand(
      "nn",
      "Neural feedback controller trained through the loop with the plant model, NARX or state-space (fig. 7.10, "
      "App. 3)");
  cmd->add_option("--plant", o->plant, "NARX or neural state-space model of the plant (identify narx, identify ss)")
      ->required();
  cmd->add_option("--ff", o->ff, "LQ feedforward controller (design lq)")->required();
  add_bandpass_option(cmd, o->bandpass, "Band-pass corners LO,HI in Hz in front of the controllers (LO = 0: low-pass only)");
  cmd->add_option("--order", o->order, "Band-pass order")->check(CLI::Range(1, 8))->capture_default_str();
  cmd->add_option("--hidden", o->design.structure.hidden, "Hidden layer widths of N1")
      ->delimiter(',')
      ->check(CLI::Range(1, 1000))
      ->capture_default_str();
  cmd->add_option("--nu", o->design.structure.nu, "Feedforward outputs u(k..k-nu) into N1")
      ->check(CLI::Range(0, 100))
      ->capture_default_str();
  cmd->add_option("--nv", o->design.structure.nv, "Past drives v(k-1..k-nv) into N1")
      ->check(CLI::Range(0, 100))
      ->capture_default_str();
  cmd->add_option("--ny", o->design.structure.ny, "Past plant outputs y(k-1..k-ny) into N1")
      ->check(CLI::Range(0, 100))
      ->capture_default_str();
  cmd->add_option("--samples", o->design.samples, "Samples of each training record (estimation, validation)")
      ->check(CLI::Range(1000L, 10000000L))
      ->capture_default_str();
  cmd->add_option("--sine-share", o->design.sine_share, "Share of each record made of stepped sines")
      ->check(CLI::Range(0.0, 1.0))
      ->capture_default_str();
  cmd->add_option("--sine-peak", o->design.sine_peak, "Steady peak of the feedforward output in the stepped sines (of the program where the chain's gain is below 1)")
      ->check(CLI::Range(1e-6, 1.0))
      ->capture_default_str();
  cmd->add_option_function<std::string>(
         "--sine-band",
         [o](const std::string& text) {
           try {
             std::tie(o->design.sine_low_hz, o->design.sine_high_hz) = parse_bandpass(text);
           } catch (const std::invalid_argument& e) {
             throw CLI::ValidationError("--sine-band", e.what());
           }
         },
         "LO,HI: the stepped sines' frequencies are drawn log-uniformly from LO to HI Hz")
      ->default_str("30,400");
  cmd->add_option("--program-share", o->design.program_share,
                  "Share of the stepped sines at a program level (the same amplitudes at every frequency), the rest "
                  "at the drive level")
      ->check(CLI::Range(0.0, 1.0))
      ->capture_default_str();
  cmd->add_flag("--level-weighting", o->design.level_weighting,
               "Weight the noise and every sine step by the inverse of its desired output's power, so small steps "
               "count as much as loud ones (J_c is then weighted too)");
  cmd->add_flag("--distortion-weighting", o->design.distortion_weighting,
               "Weight the noise and every sine step by the inverse of the uncorrected loop's error power there, so "
               "every part's distortion counts in dB alike (J_c is then weighted too)")
      ->excludes("--level-weighting");
  cmd->add_option_function<std::string>(
         "--desired",
         [o](const std::string& name) { o->design.desired = models::desired_response_from_name(name); },
         "What the loop output tracks: linear-model (y_lin of [7B], the thesis's), plant-small-signal (the "
         "plant model's own small-signal response to the feedforward output, so only its distortion is corrected) "
         "or plant-fundamental (on each sine step's steady part the fundamental of the uncorrected loop's output, so "
         "only its harmonics are; the noise as plant-small-signal)")
      ->check(CLI::IsMember({"linear-model", "plant-small-signal", "plant-fundamental"}))
      ->default_str("linear-model");
  cmd->add_option("--iterations", o->design.training.max_iterations, "Levenberg-Marquardt iterations")
      ->check(CLI::Range(0, 100000))
      ->capture_default_str();
  cmd->add_option("--rail-penalty", o->design.training.rail_penalty, "Weight of the time-at-the-rails penalty")
      ->check(CLI::Range(0.0, 1e12))
      ->capture_default_str();
  cmd->add_option("--dc-penalty", o->design.training.dc_penalty,
                  "Weight of the drive-offset penalty (N1's output below 5 Hz, which the plant cannot show; 0: off)")
      ->check(CLI::Range(0.0, 1e12))
      ->capture_default_str();
  cmd->add_option("--seed", o->design.seed, "Seed of the training records and initial weights")->capture_default_str();
  cmd->add_option("--restarts", o->design.restarts,
                 "Trainings from different initial weights (seed, seed+1, ...); --keep says which is kept")
      ->check(CLI::Range(1, 1000))
      ->capture_default_str();
  cmd->add_option_function<std::string>(
         "--keep", [o](const std::string& name) { o->design.keep = models::restart_choice_from_name(name); },
         "Which restart is kept: validation-jc (the lowest validation J_c on the plant model) or worst-probe (the "
         "largest THD cut at its worst --probes frequency on the plant model, at the --sine-peak drive)")
      ->check(CLI::IsMember({"validation-jc", "worst-probe"}))
      ->default_str("validation-jc");
  cmd->add_option("--probes", o->design.probe_hz, "Probe frequencies in Hz that --keep worst-probe scores by (evaluate's)")
      ->delimiter(',')
      ->check(CLI::PositiveNumber)
      ->default_str("40,80,160,320");
  auto* tune_on = cmd->add_option("--tune-on", o->tune_on,
                  "Tune on a device: a virtual transducer (preset or plant JSON file) standing in for the real one. "
                  "The records' drives are played into it; on each sine step its harmonics (fitted, so the sensor noise "
                  "between them is left out) are what the loop is trained to remove, on the noise its departure from "
                  "the plant model's target; the gradients are still the plant model's (needs --desired "
                  "plant-fundamental)");
  cmd->add_option("--tune-playbacks", o->design.device_playbacks,
                  "With --tune-on: play each drive this many times and average the device's outputs (its sensor "
                  "noise's power falls by that factor)")
      ->check(CLI::Range(1, 10000))
      ->needs(tune_on)
      ->capture_default_str();
  auto* start_from = cmd->add_option("--start-from", o->start_from,
                                     "Train on from a controller file (its structure, weights and knee; one training)");
  for (const char* fresh : {"--hidden", "--nu", "--nv", "--ny", "--restarts"}) start_from->excludes(fresh);
  cmd->add_option("--out", o->out, "Controller file to write (JSON)")->required();
  cmd->footer(
      "Example:\n  panelbass design nn --plant nn.json --ff ff.json --bandpass 20,1200 --hidden 8 --out fb.json\n"
      "  panelbass design nn --plant nn.json --ff ff.json --restarts 4 --keep worst-probe --out fb.json\n"
      "  panelbass design nn --plant ss.json --ff ff.json --hidden 8 --out fb.json   (ss.json: identify ss)\n"
      "  panelbass design nn --plant nn.json --ff ff.json --desired plant-fundamental --tune-on panel-exciter \\\n"
      "      --tune-playbacks 8 --out fb.json");
  cmd->callback([o] { run_design_nn(*o); });
}

}  // namespace panelbass::cli
