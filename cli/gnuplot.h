#pragma once
// Figures drawn by gnuplot (Debian package gnuplot-nox): a figure is a gnuplot script plus one data file
// (blocks separated by two blank lines, addressed by `index`), both kept next to the image so that a
// reader can re-run or restyle it. gnuplot is run as a child process; nothing is plotted by hand.

#include <Eigen/Core>
#include <filesystem>
#include <string>
#include <vector>

namespace panelbass::cli {

/// The image format written.
enum class PlotFormat { png, svg };

/// "png" or "svg" → PlotFormat; throws std::invalid_argument otherwise.
PlotFormat parse_plot_format(const std::string& name);
/// The file extension (without the dot) and the MIME type of `format`.
std::string extension_of(PlotFormat format);
std::string mime_type_of(PlotFormat format);

/// The gnuplot executable found on PATH; throws std::runtime_error naming gnuplot and the package
/// (gnuplot-nox) when there is none.
std::filesystem::path find_gnuplot();

/// `v` written with `digits` significant digits (printf's %g), for titles, ranges and labels.
std::string gnuplot_number(double v, int digits = 3);

/// `text` as a single-quoted gnuplot string ('' stands for a quote inside).
std::string gnuplot_quoted(const std::string& text);

/// One figure: data blocks, script lines, then render() writes <dir>/<name>.{gp,dat,png|svg} and runs gnuplot.
class GnuplotFigure {
 public:
  /// A figure `name` (a file stem) of width×height pixels.
  GnuplotFigure(std::string name, int width = 900, int height = 540);

  /// Appends a data block whose rows are the rows of `columns` (equal lengths; non-finite → NaN, which
  /// gnuplot treats as missing); returns its index for `index N` in a plot command.
  int add_block(const std::vector<Eigen::VectorXd>& columns);

  /// Appends a line of script (after the terminal and output are set).
  GnuplotFigure& operator<<(const std::string& line);

  /// The data file as gnuplot should name it in a plot command (quoted).
  std::string data() const;

  /// Writes the script and data into `dir` and runs gnuplot there; returns the image path. Throws
  /// std::runtime_error with gnuplot's first error line if it fails.
  std::filesystem::path render(const std::filesystem::path& dir, PlotFormat format) const;

 private:
  std::string name_;
  int width_, height_;
  std::string data_;
  int blocks_ = 0;
  std::vector<std::string> lines_;
};

}  // namespace panelbass::cli
