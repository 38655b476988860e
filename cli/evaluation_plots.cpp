#include "cli/evaluation_plots.h"

#include <algorithm>
#include <cmath>
#include <iterator>
#include <string>
#include <vector>

namespace panelbass::cli {
namespace {

constexpr const char* kColours[] = {"#7f7f7f", "#1f77b4", "#d62728", "#2ca02c"};

std::string colour(std::size_t i) { return std::string("lc rgb '") + kColours[i % std::size(kColours)] + "'"; }

// A level of −inf (a harmonic that is exactly zero) is drawn at the plot's floor instead of vanishing.
constexpr double kFloorDb = -100.0;

}  // namespace

std::filesystem::path plot_evaluation_response(const evaluation::ChainEvaluation& e, const evaluation::EvaluationOptions& o,
                                               const std::filesystem::path& dir, PlotFormat format) {
  GnuplotFigure fig("evaluation_response");
  std::string plot = "plot ";
  for (std::size_t r = 0; r < e.rows.size(); ++r) {
    const evaluation::EvaluationRow& row = e.rows[r];
    const int block = fig.add_block({row.response_hz, row.response_db});
    plot += (r == 0 ? fig.data() : std::string("     ''")) + " index " + std::to_string(block) +
            " using 1:2 with lines lw 1.8 " + colour(r) + " title " +
            gnuplot_quoted(row.name + " (ripple " + gnuplot_number(row.ripple_db, 3) + " dB)") +
            (r + 1 < e.rows.size() ? ", \\\n" : "");
  }
  fig << "set title " + gnuplot_quoted("Response program → measured output on the virtual transducer (H1, white noise at " +
                                       gnuplot_number(e.noise_amplitude, 3) + ")")
      << "set xlabel 'frequency (Hz)'"
      << "set ylabel 'magnitude (dB)'"
      << "set logscale x"
      << "set xrange [10:*]"
      << "set key bottom right box opaque"
      << "set object 1 rect from " + gnuplot_number(o.ripple_low_hz, 8) + ", graph 0 to " +
             gnuplot_number(o.ripple_high_hz, 8) + ", graph 1 fc rgb '#f2f2f2' fs solid noborder behind"
      << plot;
  return fig.render(dir, format);
}

std::filesystem::path plot_evaluation_harmonics(const evaluation::ChainEvaluation& e, const std::filesystem::path& dir,
                                                PlotFormat format) {
  GnuplotFigure fig("evaluation_harmonics", 1100, 560);
  // x positions: harmonic h + 2 of probe p at p·(H + 1) + h (H harmonics per probe, a gap between probes),
  // each configuration's bar offset within that slot
  const std::size_t harmonics = e.rows.empty() || e.rows.front().probes.empty()
                                    ? 0
                                    : e.rows.front().probes.front().harmonics_db.size();
  const double stride = static_cast<double>(harmonics + 1);
  const double width = 0.8 / static_cast<double>(std::max<std::size_t>(1, e.rows.size()));
  std::string plot = "plot ";
  for (std::size_t r = 0; r < e.rows.size(); ++r) {
    std::vector<double> x, level;
    for (std::size_t p = 0; p < e.rows[r].probes.size(); ++p) {
      const auto& db = e.rows[r].probes[p].harmonics_db;
      for (std::size_t h = 0; h < db.size(); ++h) {
        x.push_back(static_cast<double>(p) * stride + static_cast<double>(h) - 0.4 + width * (static_cast<double>(r) + 0.5));
        level.push_back(std::isfinite(db[h]) ? std::max(db[h], kFloorDb) : kFloorDb);
      }
    }
    const int block = fig.add_block({Eigen::Map<Eigen::VectorXd>(x.data(), static_cast<Eigen::Index>(x.size())),
                                     Eigen::Map<Eigen::VectorXd>(level.data(), static_cast<Eigen::Index>(level.size()))});
    plot += (r == 0 ? fig.data() : std::string("     ''")) + " index " + std::to_string(block) +
            " using 1:($2 - " + gnuplot_number(kFloorDb, 4) + "):(" + gnuplot_number(width, 4) +
            ") with boxes fs solid 0.8 noborder " + colour(r) + " title " + gnuplot_quoted(e.rows[r].name) +
            (r + 1 < e.rows.size() ? ", \\\n" : "");
  }
  std::string tics;
  if (!e.rows.empty()) {
    for (std::size_t p = 0; p < e.rows.front().probes.size(); ++p) {
      const evaluation::ProbeResult& probe = e.rows.front().probes[p];
      for (std::size_t h = 0; h < harmonics; ++h) {
        const std::string label = "H" + std::to_string(h + 2) + (h == 0 ? "\\n" + gnuplot_number(probe.frequency_hz, 4) + " Hz" : "");
        tics += (tics.empty() ? "" : ", ") + std::string("\"") + label + "\" " +
                gnuplot_number(static_cast<double>(p) * stride + static_cast<double>(h), 6);
      }
    }
  }
  // bars grow up from the floor; the y tics read the level relative to the fundamental
  fig << "set title 'Harmonics at each probe sine, relative to the fundamental (sensor noise off)'"
      << "set ylabel 'level relative to the fundamental (dB)'"
      << "set bmargin 4"
      << "set xtics (" + tics + ") scale 0"
      << "set xrange [-1:" + gnuplot_number(stride * static_cast<double>(e.rows.empty() ? 1 : e.rows.front().probes.size()) - 1.0, 6) + "]"
      << "set yrange [0:" + gnuplot_number(-kFloorDb + 10.0, 4) + "]"
      << "set ytics ('-100' 0, '-80' 20, '-60' 40, '-40' 60, '-20' 80, '0' 100, '+10' 110)"
      << "set grid ytics"
      << "set key top right box opaque"
      << plot;
  return fig.render(dir, format);
}

std::filesystem::path plot_level_sweep(const evaluation::LevelSweep& sweep, const std::filesystem::path& dir,
                                       PlotFormat format) {
  GnuplotFigure fig("evaluation_thd_vs_level", 1000, 600);
  std::string plot = "plot ";
  bool first = true;
  for (std::size_t c = 0; c < sweep.curves.size(); ++c) {
    const evaluation::LevelCurve& curve = sweep.curves[c];
    for (const bool chain : {false, true}) {
      std::vector<double> level, thd;
      for (const evaluation::LevelPoint& p : curve.points) {
        if (!p.reachable) continue;
        level.push_back((chain ? p.chain : p.plant).fundamental);
        thd.push_back((chain ? p.chain : p.plant).thd_pct);
      }
      if (level.empty()) continue;
      const int block = fig.add_block({Eigen::Map<Eigen::VectorXd>(level.data(), static_cast<Eigen::Index>(level.size())),
                                       Eigen::Map<Eigen::VectorXd>(thd.data(), static_cast<Eigen::Index>(thd.size()))});
      plot += (first ? fig.data() : std::string(", \\\n     ''")) + " index " + std::to_string(block) +
              " using 1:2 with linespoints lw 1.8 pt 7 ps 0.6 " + (chain ? "dt 1 " : "dt 2 ") + colour(c + 1) +
              " title " + gnuplot_quoted(gnuplot_number(curve.frequency_hz, 4) + " Hz " + (chain ? "chain" : "plant alone"));
      first = false;
    }
  }
  fig << "set title 'THD against the output level (sensor fundamental), chain and plant alone at equal output level'"
      << "set xlabel 'fundamental at the sensor (V)'"
      << "set ylabel 'THD (%)'"
      << "set logscale xy"
      << "set grid xtics ytics mxtics mytics"
      << "set key outside right box opaque"
      << (first ? std::string("plot NaN notitle") : plot);
  return fig.render(dir, format);
}

}  // namespace panelbass::cli
