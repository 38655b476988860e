#include "cli/report_output.h"

#include <unistd.h>

#include <memory>
#include <random>
#include <stdexcept>
#include <system_error>

namespace panelbass::cli {
namespace {

namespace fs = std::filesystem;

// A fresh directory under the system's temporary folder, removed (with its contents) with the object.
class ScratchDirectory {
 public:
  explicit ScratchDirectory(const std::string& prefix) {
    path_ = fs::temp_directory_path() /
            (prefix + "-" + std::to_string(::getpid()) + "-" + std::to_string(std::random_device{}()));
    fs::create_directories(path_);
  }
  ~ScratchDirectory() {
    std::error_code ignored;
    fs::remove_all(path_, ignored);
  }
  ScratchDirectory(const ScratchDirectory&) = delete;
  ScratchDirectory& operator=(const ScratchDirectory&) = delete;
  const fs::path& path() const { return path_; }

 private:
  fs::path path_;
};

}  // namespace

void check_output_file(const std::string& option, const std::string& path) {
  const fs::path parent = fs::absolute(path).parent_path();
  if (!fs::is_directory(parent)) {
    throw std::invalid_argument(option + " " + path + ": directory " + parent.string() + " does not exist");
  }
  if (fs::is_directory(path)) throw std::invalid_argument(option + " " + path + ": is a directory");
}

void ReportOutputOptions::add_to(CLI::App* cmd, const std::string& out_help, const std::string& html_help) {
  cmd->add_option("--out", out, out_help)->required();
  cmd->add_option("--html", html, html_help);
  cmd->add_option("--plots", plots, "Directory for the figures, their gnuplot scripts and data (created)");
  cmd->add_option("--plot-format", plot_format, "png or svg")->check(CLI::IsMember({"png", "svg"}))->capture_default_str();
}

PlotFormat ReportOutputOptions::prepare() const {
  check_output_file("--out", out);
  if (!html.empty()) check_output_file("--html", html);
  const PlotFormat format = parse_plot_format(plot_format);
  if (plotting()) find_gnuplot();
  if (!plots.empty()) fs::create_directories(plots);
  return format;
}

void ReportOutputOptions::name_outputs(nlohmann::json& result) const {
  result["out"] = out;
  result["html"] = html.empty() ? nlohmann::json(nullptr) : nlohmann::json(html);
  result["plots"] = nullptr;
}

void ReportOutputOptions::draw_figures(const std::string& scratch_prefix, nlohmann::json& result,
                                       const std::function<std::vector<ReportFigure>(const fs::path&)>& draw,
                                       const std::function<void(const std::vector<ReportFigure>&)>& write_page) const {
  if (!plotting()) return;
  std::unique_ptr<ScratchDirectory> scratch;
  if (plots.empty()) scratch = std::make_unique<ScratchDirectory>(scratch_prefix);
  const std::vector<ReportFigure> figures = draw(plots.empty() ? scratch->path() : fs::path(plots));
  if (!plots.empty()) {
    nlohmann::json paths = nlohmann::json::object();
    for (const ReportFigure& f : figures) paths[f.name] = (fs::path(plots) / f.path.filename()).string();
    result["plots"] = paths;
  }
  if (!html.empty()) write_page(figures);
}

}  // namespace panelbass::cli
