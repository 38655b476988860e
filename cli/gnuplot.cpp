#include "cli/gnuplot.h"

#include <fcntl.h>
#include <spawn.h>
#include <sys/wait.h>
#include <unistd.h>

#include <cerrno>
#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <cstring>
#include <fstream>
#include <sstream>
#include <stdexcept>

#include "models/io/number_text.h"

extern char** environ;

namespace panelbass::cli {
namespace fs = std::filesystem;

namespace {

const char* const kMissing =
    "gnuplot not found on PATH; plots need it: install the Debian package gnuplot-nox "
    "(apt-get install gnuplot-nox, or scripts/bootstrap.sh)";

std::string first_error_line(const fs::path& log) {
  std::ifstream in(log);
  std::string line, first;
  while (std::getline(in, line)) {
    if (line.find_first_not_of(" \t^") == std::string::npos) continue;  // gnuplot's caret markers
    if (first.empty()) first = line;
    if (line.find("rror") != std::string::npos) return line;
  }
  return first.empty() ? "no message" : first;
}

void write_file(const fs::path& path, const std::string& text) {
  std::ofstream out(path, std::ios::binary | std::ios::trunc);
  out << text;
  if (!out.flush()) throw std::runtime_error(path.string() + ": cannot write");
}

}  // namespace

PlotFormat parse_plot_format(const std::string& name) {
  if (name == "png") return PlotFormat::png;
  if (name == "svg") return PlotFormat::svg;
  throw std::invalid_argument("plot format must be png or svg, got \"" + name + "\"");
}

std::string extension_of(PlotFormat format) { return format == PlotFormat::png ? "png" : "svg"; }

std::string mime_type_of(PlotFormat format) { return format == PlotFormat::png ? "image/png" : "image/svg+xml"; }

fs::path find_gnuplot() {
  const char* path = std::getenv("PATH");
  std::stringstream dirs(path != nullptr ? path : "");
  std::string dir;
  while (std::getline(dirs, dir, ':')) {
    if (dir.empty()) continue;
    const fs::path candidate = fs::path(dir) / "gnuplot";
    if (::access(candidate.c_str(), X_OK) == 0) return candidate;
  }
  throw std::runtime_error(kMissing);
}

std::string gnuplot_number(double v, int digits) { return models::number_text(v, digits); }

std::string gnuplot_quoted(const std::string& text) {
  std::string out = "'";
  for (const char c : text) out += c == '\'' ? std::string("''") : std::string(1, c);
  return out + "'";
}

GnuplotFigure::GnuplotFigure(std::string name, int width, int height)
    : name_(std::move(name)), width_(width), height_(height) {}

int GnuplotFigure::add_block(const std::vector<Eigen::VectorXd>& columns) {
  if (columns.empty()) throw std::invalid_argument("plot " + name_ + ": a data block without columns");
  const Eigen::Index rows = columns.front().size();
  for (const auto& c : columns) {
    if (c.size() != rows) throw std::invalid_argument("plot " + name_ + ": data columns differ in length");
  }
  std::ostringstream out;
  out.precision(10);
  if (blocks_ > 0) out << "\n\n";
  for (Eigen::Index r = 0; r < rows; ++r) {
    for (std::size_t c = 0; c < columns.size(); ++c) {
      if (c > 0) out << ' ';
      const double v = columns[c][r];
      if (std::isfinite(v)) {
        out << v;
      } else {
        out << "NaN";
      }
    }
    out << '\n';
  }
  data_ += out.str();
  return blocks_++;
}

GnuplotFigure& GnuplotFigure::operator<<(const std::string& line) {
  lines_.push_back(line);
  return *this;
}

std::string GnuplotFigure::data() const { return gnuplot_quoted(name_ + ".dat"); }

fs::path GnuplotFigure::render(const fs::path& dir, PlotFormat format) const {
  const fs::path image = dir / (name_ + "." + extension_of(format));
  const fs::path script = dir / (name_ + ".gp");
  const fs::path log = dir / (name_ + ".log");
  std::ostringstream gp;
  gp << "# " << name_ << ": written by panelbass; run `gnuplot " << name_ << ".gp` in this folder to redraw.\n";
  const std::string size = std::to_string(width_) + "," + std::to_string(height_);
  if (format == PlotFormat::png) {
    // pngcairo draws antialiased lines and UTF-8 text; the libgd png terminal is the fallback.
    gp << "if (strstrt(GPVAL_TERMINALS, 'pngcairo') > 0) {\n"
       << "  set terminal pngcairo size " << size << " enhanced font 'DejaVu Sans,10'\n"
       << "} else {\n"
       << "  set terminal png size " << size << " enhanced\n"
       << "}\n";
  } else {
    gp << "set terminal svg size " << size << " enhanced font 'DejaVu Sans,10' background rgb 'white'\n";
  }
  gp << "set output " << gnuplot_quoted(image.filename().string()) << "\n"
     << "set datafile missing 'NaN'\n"
     << "set grid lc rgb '#dddddd'\n";
  for (const std::string& line : lines_) gp << line << "\n";
  gp << "unset output\n";
  write_file(script, gp.str());
  write_file(dir / (name_ + ".dat"), data_);

  const fs::path gnuplot = find_gnuplot();
  posix_spawn_file_actions_t actions;
  posix_spawn_file_actions_init(&actions);
  posix_spawn_file_actions_addopen(&actions, STDIN_FILENO, "/dev/null", O_RDONLY, 0);
  posix_spawn_file_actions_addopen(&actions, STDOUT_FILENO, log.c_str(), O_WRONLY | O_CREAT | O_TRUNC, 0644);
  posix_spawn_file_actions_adddup2(&actions, STDOUT_FILENO, STDERR_FILENO);
  // gnuplot resolves the data file and the output relative to its working directory: start it in `dir`
  // (posix_spawn_file_actions_addchdir_np, glibc ≥ 2.29).
  posix_spawn_file_actions_addchdir_np(&actions, dir.c_str());
  const std::string program = gnuplot.string(), script_name = script.filename().string();
  std::vector<char*> argv{const_cast<char*>(program.c_str()), const_cast<char*>(script_name.c_str()), nullptr};
  pid_t pid = 0;
  const int spawned = posix_spawn(&pid, program.c_str(), &actions, nullptr, argv.data(), environ);
  posix_spawn_file_actions_destroy(&actions);
  if (spawned != 0) {
    if (spawned == ENOENT) throw std::runtime_error(kMissing);
    throw std::runtime_error("cannot run " + program + ": " + std::strerror(spawned));
  }
  int status = 0;
  while (::waitpid(pid, &status, 0) < 0) {
    if (errno != EINTR) throw std::runtime_error("waiting for gnuplot: " + std::string(std::strerror(errno)));
  }
  if (!WIFEXITED(status) || WEXITSTATUS(status) != 0) {
    throw std::runtime_error("gnuplot failed on " + script.string() + ": " + first_error_line(log));
  }
  std::error_code ignored;
  if (!fs::exists(image) || fs::file_size(image, ignored) == 0) {
    throw std::runtime_error("gnuplot wrote no image for " + script.string() + ": " + first_error_line(log));
  }
  // gnuplot's warnings stay in the log only when there were any.
  if (fs::file_size(log, ignored) == 0) fs::remove(log, ignored);
  return image;
}

}  // namespace panelbass::cli
