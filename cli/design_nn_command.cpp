// `panelbass design nn`: the design-nn use case (usecases/design_nn.h) on model files — the neural feedback
// controller trained through the loop with a plant model behind an LQ feedforward. Flags into the request (their
// defaults are the request's), the report printed and the controller written.
#include <map>
#include <memory>
#include <string>
#include <tuple>
#include <vector>

#include "cli/band_pass_option.h"
#include "cli/commands.h"
#include "cli/json_output.h"
#include "cli/usecase_door.h"
#include "models/control/lq_feedforward.h"
#include "models/io/json_file.h"
#include "models/plant/plant_presets.h"
#include "usecases/design_nn.h"

namespace panelbass::cli {
namespace {

// The flags of `design nn`'s request fields, for its refusals.
const std::map<std::string, std::string> kDesignNnFlags = {
    {"max_iterations", "--iterations"}, {"band_pass", "--bandpass"},    {"band_pass.order", "--order"},
    {"probes_hz", "--probes"},          {"tune_playbacks", "--tune-playbacks"}, {"sine_band", "--sine-band"},
    {"weighting", "--distortion-weighting"}};

// The options of `design nn`; the defaults are the request's (usecases::DesignNnRequest).
struct DesignNnOptions {
  std::string plant, ff, out;
  std::string tune_on;     // a device to tune on: a plant preset or file (empty: the plant model alone)
  std::string start_from;  // a controller to train on from (empty: fresh initial weights)
  std::string bandpass;    // LO,HI (empty: the feedforward's own, as its meta records it)
  int order = usecases::BandPass{}.order;
  usecases::DesignNnRequest request;
};

void run_design_nn(DesignNnOptions o, bool order_given) {
  usecases::DesignNnRequest& q = o.request;
  q.plant_name = o.plant;
  q.feedforward_name = o.ff;
  if (!o.bandpass.empty()) {
    const auto [lo, hi] = parse_bandpass(o.bandpass);
    q.band_pass = usecases::BandPass{lo, hi, o.order};
  }
  if (!o.tune_on.empty()) q.tune_on = models::plant_from_name_or_file(o.tune_on);
  q.start_from = o.start_from;
  const RequestSpelling spelling{kDesignNnFlags,
                                 {{"plant_model", o.plant}, {"feedforward_model", o.ff}, {"start_from", o.start_from}}};
  run_use_case([&] { usecases::check(q); }, spelling);  // bad usage before any file is read
  q.plant_model = models::read_json_file(o.plant);
  q.feedforward_model = models::read_json_file(o.ff);
  if (!q.band_pass && order_given) {  // the feedforward's corners at another order
    q.band_pass = usecases::band_pass_of(models::lq_feedforward_from_json(q.feedforward_model));
    q.band_pass->order = o.order;
  }
  if (!o.start_from.empty()) q.start_from_model = models::read_json_file(o.start_from);
  BarProgress bar("design nn");
  const usecases::DesignNnReport report = run_use_case([&] { return usecases::design_nn(q, bar); }, spelling);
  models::write_json_file(o.out, models::neural_feedback_to_json(report.controller));
  nlohmann::json result = report.summary;
  result["out"] = o.out;
  result["history"] = report.history;
  print_result(result);
}

}  // namespace

void add_design_nn(CLI::App& design) {
  auto o = std::make_shared<DesignNnOptions>();
  models::FeedbackDesignOptions& d = o->request.design;
  CLI::App* cmd = design.add_subcommand(
      "nn",
      "Neural feedback controller trained through the loop with the plant model, NARX or state-space (fig. 7.10, "
      "App. 3)");
  cmd->add_option("--plant", o->plant, "NARX or neural state-space model of the plant (identify narx, identify ss)")
      ->required();
  cmd->add_option("--ff", o->ff, "LQ feedforward controller (design lq)")->required();
  add_bandpass_option(cmd, o->bandpass,
                      "Band-pass corners LO,HI in Hz in front of the controllers (LO = 0: low-pass only; default: the "
                      "band the feedforward was designed behind, as its file records it)");
  CLI::Option* order = cmd->add_option(
      "--order", o->order, "Band-pass order: of --bandpass (default 2), or alone the feedforward's corners at this order");
  cmd->add_option("--hidden", d.structure.hidden, "Hidden layer widths of N1")
      ->delimiter(',')
      ->capture_default_str();
  cmd->add_option("--nu", d.structure.nu, "Feedforward outputs u(k..k-nu) into N1")
      ->capture_default_str();
  cmd->add_option("--nv", d.structure.nv, "Past drives v(k-1..k-nv) into N1")
      ->capture_default_str();
  cmd->add_option("--ny", d.structure.ny, "Past plant outputs y(k-1..k-ny) into N1")
      ->capture_default_str();
  cmd->add_option("--samples", d.samples, "Samples of each training record (estimation, validation)")
      ->capture_default_str();
  cmd->add_option("--sine-share", d.sine_share, "Share of each record made of stepped sines")
      ->capture_default_str();
  cmd->add_option("--sine-peak", d.sine_peak, "Steady peak of the feedforward output in the stepped sines (of the program where the chain's gain is below 1)")
      ->capture_default_str();
  cmd->add_option_function<std::string>(
         "--sine-band",
         [o](const std::string& text) {
           try {
             std::tie(o->request.design.sine_low_hz, o->request.design.sine_high_hz) = parse_bandpass(text);
           } catch (const std::invalid_argument& e) {
             throw CLI::ValidationError("--sine-band", e.what());
           }
         },
         "LO,HI: the stepped sines' frequencies are drawn log-uniformly from LO to HI Hz")
      ->default_str("30,400");
  cmd->add_option("--program-share", d.program_share,
                  "Share of the stepped sines at a program level (the same amplitudes at every frequency), the rest "
                  "at the drive level")
      ->capture_default_str();
  cmd->add_flag("--level-weighting", d.level_weighting,
               "Weight the noise and every sine step by the inverse of its desired output's power, so small steps "
               "count as much as loud ones (J_c is then weighted too)");
  cmd->add_flag("--distortion-weighting", d.distortion_weighting,
               "Weight the noise and every sine step by the inverse of the uncorrected loop's error power there, so "
               "every part's distortion counts in dB alike (J_c is then weighted too)")
      ->excludes("--level-weighting");
  cmd->add_option_function<std::string>(
         "--desired",
         [o](const std::string& name) { o->request.design.desired = models::desired_response_from_name(name); },
         "What the loop output tracks: linear-model (y_lin of [7B], the thesis's), plant-small-signal (the "
         "plant model's own small-signal response to the feedforward output, so only its distortion is corrected) "
         "or plant-fundamental (on each sine step's steady part the fundamental of the uncorrected loop's output, so "
         "only its harmonics are; the noise as plant-small-signal)")
      ->check(CLI::IsMember({"linear-model", "plant-small-signal", "plant-fundamental"}))
      ->default_str("linear-model");
  cmd->add_option("--iterations", d.training.max_iterations, "Levenberg-Marquardt iterations")
      ->capture_default_str();
  cmd->add_option("--rail-penalty", d.training.rail_penalty, "Weight of the time-at-the-rails penalty")
      ->capture_default_str();
  cmd->add_option("--dc-penalty", d.training.dc_penalty,
                  "Weight of the drive-offset penalty (N1's output below 5 Hz, which the plant cannot show; 0: off)")
      ->capture_default_str();
  cmd->add_option("--seed", d.seed, "Seed of the training records and initial weights")->capture_default_str();
  cmd->add_option("--restarts", d.restarts,
                 "Trainings from different initial weights (seed, seed+1, ...); --keep says which is kept")
      ->capture_default_str();
  cmd->add_option_function<std::string>(
         "--keep", [o](const std::string& name) { o->request.design.keep = models::restart_choice_from_name(name); },
         "Which restart is kept: validation-jc (the lowest validation J_c on the plant model) or worst-probe (the "
         "largest THD cut at its worst --probes frequency on the plant model, at the --sine-peak drive)")
      ->check(CLI::IsMember({"validation-jc", "worst-probe"}))
      ->default_str("validation-jc");
  cmd->add_option("--probes", d.probe_hz, "Probe frequencies in Hz that --keep worst-probe scores by (evaluate's)")
      ->delimiter(',')
      ->default_str("40,80,160,320");
  auto* tune_on = cmd->add_option("--tune-on", o->tune_on,
                  "Tune on a device: a virtual transducer (preset or plant JSON file) standing in for the real one. "
                  "The records' drives are played into it; on each sine step its harmonics (fitted, so the sensor noise "
                  "between them is left out) are what the loop is trained to remove, on the noise its departure from "
                  "the plant model's target; the gradients are still the plant model's (needs --desired "
                  "plant-fundamental)");
  cmd->add_option("--tune-playbacks", d.device_playbacks,
                  "With --tune-on: play each drive this many times and average the device's outputs (its sensor "
                  "noise's power falls by that factor)")
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
  cmd->callback([o, order] { run_design_nn(*o, order->count() > 0); });
}

}  // namespace panelbass::cli
