// `panelbass design …`: controllers designed on identified models (thesis ch. 7). One helper per
// subcommand; `design lq` is the LQ feedforward controller of [7A]/[7B] behind a Butterworth band-pass,
// tracking a flat response or a target band (--target-highpass).

#include <Eigen/Eigenvalues>
#include <algorithm>
#include <cmath>
#include <complex>
#include <cstdint>
#include <cstdio>
#include <filesystem>
#include <limits>
#include <map>
#include <memory>
#include <numbers>
#include <string>
#include <utility>
#include <variant>
#include <vector>

#include "cli/band_pass_option.h"
#include "cli/commands.h"
#include "cli/gnuplot.h"
#include "cli/json_output.h"
#include "cli/usecase_door.h"
#include "dsp/butterworth.h"
#include "dsp/decibels.h"
#include "dsp/frequency_grid.h"
#include "models/io/json_file.h"
#include "models/io/roots_json.h"
#include "models/kinds/model_file.h"
#include "models/linear/frequency_response.h"
#include "models/linear/linear_model.h"
#include "models/control/lq_feedforward.h"
#include "models/control/lq_weight_search.h"
#include "usecases/design_lq.h"

namespace panelbass::cli {
namespace {

namespace fs = std::filesystem;

constexpr double kNaN = std::numeric_limits<double>::quiet_NaN();

// The flags of `design lq`'s request fields (usecases/design_lq.h), for its refusals.
const std::map<std::string, std::string> kDesignLqFlags = {
    {"plant_model", "--model"},   {"r", "--R"},          {"r0", "--R0"},      {"max_input", "--max-input"},
    {"band_pass.order", "--order"}, {"band_pass", "--bandpass"}, {"target_highpass", "--target-highpass"},
    {"noise_samples", "--samples"}};

// The options of `design lq`; the defaults are the request's (usecases::DesignLqRequest).
struct DesignLqOptions {
  std::string model, out, plots;
  double R = models::LqWeights{}.R;
  double max_input = 0.0;  // given: search R for this safe noise amplitude instead
  double R0 = usecases::DesignLqRequest{}.r0;
  std::string bandpass = band_pass_text(usecases::DesignLqRequest{}.band_pass);
  std::string target_highpass;  // "HZ[,ORDER]": the desired response's band (empty: flat, the thesis's)
  int order = usecases::DesignLqRequest{}.band_pass.order;
  long samples = usecases::DesignLqRequest{}.noise_samples;
  std::uint64_t seed = usecases::DesignLqRequest{}.seed;
  std::string plot_format = "png";
};

// "HZ[,ORDER]" → the target band's corner and Butterworth order (2 when left out); the range of HZ is
// checked by models::design_lq, which knows fs.
std::pair<double, int> parse_target_highpass(const std::string& text) {
  const std::string what = "--target-highpass: expected HZ or HZ,ORDER (ORDER 1..8), got \"" + text + "\"";
  const std::size_t comma = text.find(',');
  double hz = 0.0;
  int order = 2;
  if (!CLI::detail::lexical_cast(text.substr(0, comma), hz) || !std::isfinite(hz)) throw std::invalid_argument(what);
  if (comma != std::string::npos &&
      (!CLI::detail::lexical_cast(text.substr(comma + 1), order) || order < 1 || order > 8)) {
    throw std::invalid_argument(what);
  }
  return {hz, order};
}

// Throws unless the file `path` could be created: its directory exists and it is not a directory.
void check_output_file(const std::string& option, const std::string& path) {
  const fs::path parent = fs::absolute(path).parent_path();
  if (!fs::is_directory(parent)) {
    throw std::invalid_argument(option + " " + path + ": directory " + parent.string() + " does not exist");
  }
  if (fs::is_directory(path)) throw std::invalid_argument(option + " " + path + ": is a directory");
}

// 20·log10|H| of `ss` at each of `f` (Hz), NaN where H = 0.
Eigen::VectorXd magnitude_db(const models::StateSpace& ss, const Eigen::VectorXd& f, double fs) {
  return dsp::magnitude_db(models::frequency_response(ss, f, fs));
}

// Figs. 7.3/7.4/7.6: poles and zeros of the linear model beside those of the controlled model.
fs::path plot_lq_pole_zero(const models::LqFeedforward& ff, const fs::path& dir, PlotFormat format) {
  GnuplotFigure f("poles_zeros", 1300, 660);
  Eigen::VectorXd cx(361), cy(361);
  for (int k = 0; k <= 360; ++k) {
    cx[k] = std::cos(k * std::numbers::pi / 180.0);
    cy[k] = std::sin(k * std::numbers::pi / 180.0);
  }
  f.add_block({cx, cy});
  const auto block_of = [&f](const Eigen::VectorXcd& roots) {
    if (roots.size() == 0) return f.add_block({Eigen::VectorXd::Constant(1, kNaN), Eigen::VectorXd::Constant(1, kNaN)});
    return f.add_block({roots.real(), roots.imag()});
  };
  const Eigen::VectorXcd model_poles =
      ff.plant.order() > 0 ? Eigen::EigenSolver<Eigen::MatrixXd>(ff.plant.A, false).eigenvalues() : Eigen::VectorXcd(0);
  // State feedback leaves the zeros of y/u where they are: those of the model.
  const Eigen::VectorXcd zeros = models::to_transfer_function(ff.plant).zeros();
  block_of(model_poles);  // index 1
  block_of(zeros);        // index 2
  block_of(ff.poles());   // index 3
  const std::string weights = "R = " + gnuplot_number(ff.weights.R, 4) + ", R_0 = " + gnuplot_number(ff.weights.R0, 4);
  f << "set multiplot layout 1,2 title " + gnuplot_quoted("Poles (×) and zeros (o): linear model and model with state feedback (" +
                                                           weights + ")")
    << "set size ratio -1"
    << "set xrange [-1.6:1.6]"
    << "set yrange [-1.6:1.6]"
    << "set xlabel 'Re z'"
    << "set ylabel 'Im z'"
    << "set key bottom left box opaque font ',9'"
    << "set title 'linear model y/u*'"
    << "plot " + f.data() + " index 0 using 1:2 with lines lw 1 lc rgb '#555555' title 'unit circle', \\\n"
       "     '' index 1 using 1:2 with points pt 2 ps 2 lw 2 lc rgb '#202020' title 'poles', \\\n"
       "     '' index 2 using 1:2 with points pt 6 ps 2 lw 2 lc rgb '#1f77b4' title 'zeros'"
    << "set title " + gnuplot_quoted("controlled model y_{lin}/u (" + weights + ")")
    << "plot " + f.data() + " index 0 using 1:2 with lines lw 1 lc rgb '#555555' title 'unit circle', \\\n"
       "     '' index 3 using 1:2 with points pt 2 ps 2 lw 2 lc rgb '#d62728' title 'poles of A − BL', \\\n"
       "     '' index 2 using 1:2 with points pt 6 ps 2 lw 2 lc rgb '#1f77b4' title 'zeros'"
    << "unset multiplot";
  return f.render(dir, format);
}

// Figs. 7.5/7.7: magnitude of the linear model and of the controlled system y_lin/u, with the
// controller u*/u and the band-pass corners.
fs::path plot_lq_magnitude(const models::LqFeedforward& ff, double lo, double hi, const fs::path& dir,
                           PlotFormat format) {
  const Eigen::VectorXd f = dsp::log_spaced(1.0, 0.999 * ff.fs / 2.0, 800);
  GnuplotFigure fig("magnitude");
  fig.add_block({f, magnitude_db(ff.plant, f, ff.fs), magnitude_db(ff.desired(), f, ff.fs),
                 magnitude_db(ff.controller(), f, ff.fs)});
  fig << "set title " + gnuplot_quoted("Magnitude responses (raw units): linear model and with state feedback, R = " +
                                       gnuplot_number(ff.weights.R, 4) + ", R_0 = " + gnuplot_number(ff.weights.R0, 4))
      << "set xlabel 'frequency (Hz)'"
      << "set ylabel 'magnitude (dB)'"
      << "set logscale x"
      << "set xrange [1:" + gnuplot_number(ff.fs / 2.0, 8) + "]"
      << "set key top left box opaque";
  if (lo > 0.0) fig << "set arrow from " + gnuplot_number(lo, 8) + ", graph 0 to " + gnuplot_number(lo, 8) + ", graph 1 nohead dt 3 lc rgb '#888888'";
  fig << "set arrow from " + gnuplot_number(hi, 8) + ", graph 0 to " + gnuplot_number(hi, 8) + ", graph 1 nohead dt 3 lc rgb '#888888'"
      << "plot " + fig.data() + " index 0 using 1:2 with lines lw 1.8 lc rgb '#202020' title 'linear model y/u*', \\\n"
         "     '' index 0 using 1:3 with lines lw 1.8 dt 2 lc rgb '#d62728' title 'controlled y_{lin}/u', \\\n"
         "     '' index 0 using 1:4 with lines lw 1.2 dt 3 lc rgb '#1f77b4' title 'controller u*/u'";
  return fig.render(dir, format);
}

// `design lq` with the options given (`weight_given`: --R; `max_input_given`: --max-input).
void run_design_lq(const DesignLqOptions& o, bool weight_given, bool max_input_given) {
  usecases::DesignLqRequest q;
  q.plant_model = models::read_json_file(o.model);
  q.plant_name = o.model;
  if (weight_given) q.r = o.R;
  if (max_input_given) q.max_input = o.max_input;
  q.r0 = o.R0;
  const auto [lo, hi] = parse_bandpass(o.bandpass);
  q.band_pass = {lo, hi, o.order};
  if (!o.target_highpass.empty()) {
    const auto [hz, hp_order] = parse_target_highpass(o.target_highpass);
    q.target_highpass = usecases::TargetHighpass{hz, hp_order};
  }
  q.noise_samples = o.samples;
  q.seed = o.seed;
  check_output_file("--out", o.out);
  const PlotFormat format = parse_plot_format(o.plot_format);
  if (!o.plots.empty()) {
    find_gnuplot();
    fs::create_directories(o.plots);
  }
  BarProgress progress("design lq");
  const usecases::DesignLqReport report =
      run_use_case([&] { return usecases::design_lq(q, progress); }, {kDesignLqFlags, {{"plant_model", o.model}}});
  print_warnings("design lq", report.warnings);
  models::write_json_file(o.out, models::lq_feedforward_to_json(report.controller));
  nlohmann::json result = report.summary;
  result["out"] = o.out;
  result["plots"] = nullptr;
  if (!o.plots.empty()) {
    const fs::path dir(o.plots);
    result["plots"] = {{"poles_zeros", (dir / plot_lq_pole_zero(report.controller, dir, format).filename()).string()},
                       {"magnitude", (dir / plot_lq_magnitude(report.controller, lo, hi, dir, format).filename()).string()}};
  }
  print_result(result);
}

// `design lq`: adds the subcommand and its options to `design`.
void add_design_lq(CLI::App* design) {
  auto o = std::make_shared<DesignLqOptions>();
  CLI::App* lq = design->add_subcommand(
      "lq", "LQ feedforward controller [7A]/[7B] on a linear model, and the largest safe program amplitude");
  lq->add_option("--model", o->model, "Linear model file (JSON, from identify linear), or an ss model (linearised at rest)")->required();
  CLI::Option* r_option =
      lq->add_option("--R", o->R, "Weight on the controller output u* (> 0); small R: flatter response, larger u*")
          ->capture_default_str();
  CLI::Option* max_input_option =
      lq->add_option("--max-input", o->max_input,
                     "Instead of --R: the program peak (0 < A <= 1) that must keep u* within [-1, 1] for band-limited "
                     "white noise; R is searched (the smallest that allows it: the flattest response at that level)")
          ->excludes(r_option);
  lq->add_option("--R0", o->R0, "Weight on the model output y (>= 0)")->capture_default_str();
  add_bandpass_option(lq, o->bandpass, "Band-pass corners LO,HI in Hz before the controller (LO = 0: low-pass only)");
  lq->add_option("--target-highpass", o->target_highpass,
                 "HZ[,ORDER]: the desired response is the model's gain at mid band times a Butterworth high-pass at HZ "
                 "(0 < HZ < the band-pass's top; ORDER 1..8, default 2), flat above; without it the design regulates to a flat "
                 "response (the thesis's [7A])")
      ->check(CLI::Validator(
          [](std::string& text) {
            try {
              parse_target_highpass(text);
              return std::string();
            } catch (const std::invalid_argument& e) {
              return std::string(e.what());
            }
          },
          "HZ[,ORDER]", "target_highpass"))
      ->excludes("--max-input");
  lq->add_option("--order", o->order, "Butterworth order of the high-pass and of the low-pass (1..16)")
      ->capture_default_str();
  lq->add_option("--samples", o->samples, "Samples of uniform noise for max_input_noise")->capture_default_str();
  lq->add_option("--seed", o->seed, "Seed of that noise")->capture_default_str();
  lq->add_option("--out", o->out, "Controller file to write (JSON, kind lq_feedforward)")->required();
  lq->add_option("--plot", o->plots, "Directory for the pole-zero and magnitude figures (created)");
  lq->add_option("--plot-format", o->plot_format, "png or svg")->check(CLI::IsMember({"png", "svg"}))->capture_default_str();
  lq->footer(
      "Example (the thesis's weights, figs 7.3-7.5, and its cheap-control design, figs 7.6-7.7):\n"
      "  panelbass simulate --plant panel-exciter --signal noise --samples 12000 --seed 1 --out run.csv\n"
      "  panelbass identify linear --data run.csv --fs 3000 --method oe --scan 1:12 --val run.csv --out lin.json\n"
      "  panelbass design lq --model lin.json --R 3 --R0 20 --bandpass 20,1200 --out ff.json --plot plots/\n"
      "  panelbass design lq --model lin.json --R 1e-5 --R0 20 --bandpass 0,1200 --out ff-cheap.json\n"
      "The flattest design that still takes a program peak of 1/3 (R searched):\n"
      "  panelbass design lq --model lin.json --max-input 0.33 --R0 20 --bandpass 20,1200 --out ff-third.json\n"
      "A desired response flat above an 80 Hz 2nd-order high-pass instead of flat to DC:\n"
      "  panelbass design lq --model lin.json --R 0.1 --R0 20 --bandpass 20,1200 --target-highpass 80,2 --out ff-80.json\n"
      "The result gives safe_amplitude (the largest noise program peak keeping the drive within [-1, 1]) and, per\n"
      "program level 0.1..1, the drive's peak and the estimated peak excursion.");
  lq->callback([o, r_option, max_input_option] {
    run_design_lq(*o, r_option->count() > 0, max_input_option->count() > 0);
  });
}

}  // namespace

void register_design(CLI::App& app) {
  CLI::App* design = app.add_subcommand("design", "Design a controller on an identified model (thesis ch. 7)");
  design->require_subcommand(1);
  design->footer("Example:\n  panelbass design lq --model lin.json --R 3 --R0 20 --bandpass 20,1200 --out ff.json");
  add_design_lq(design);
  add_design_nn(*design);
  add_design_mirror(*design);
}

}  // namespace panelbass::cli
