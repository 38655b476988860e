#include "api/prometheus.h"

#include <cmath>
#include <iomanip>
#include <sstream>

namespace panelbass::api {
namespace {

// Writes one metric family with its samples ({labels, value}).
class Exposition {
 public:
  void family(const std::string& name, const char* type, const char* help) {
    out_ << "# HELP " << name << ' ' << help << "\n# TYPE " << name << ' ' << type << '\n';
  }
  void sample(const std::string& name, const std::string& labels, double value) {
    out_ << name;
    if (!labels.empty()) out_ << '{' << labels << '}';
    out_ << ' ';
    // Counts exactly (a double's default 6 digits would round 1234567 to 1.23457e+06), the rest to 10 digits.
    if (value == std::floor(value) && std::abs(value) < 1e15) {
      out_ << static_cast<long long>(value);
    } else {
      out_ << std::setprecision(10) << value;
    }
    out_ << '\n';
  }
  std::string text() const { return out_.str(); }

 private:
  std::ostringstream out_;
};

}  // namespace

std::string prometheus_text(const engine::MetricsSnapshot& m, const ServiceCounts& service) {
  Exposition e;
  const auto counter = [&e](const std::string& name, const char* help, double value) {
    e.family(name, "counter", help);
    e.sample(name, "", value);
  };
  const auto gauge = [&e](const std::string& name, const char* help, double value) {
    e.family(name, "gauge", help);
    e.sample(name, "", value);
  };
  counter("panelbass_blocks_total", "Audio blocks processed.", static_cast<double>(m.blocks));
  counter("panelbass_samples_total", "Audio samples processed.", static_cast<double>(m.samples));
  counter("panelbass_xruns_total", "Blocks that missed their deadline.", static_cast<double>(m.xruns));
  counter("panelbass_faults_total", "Times the chain dropped to its safe bypass.", static_cast<double>(m.faults));
  counter("panelbass_swaps_total", "Stages taken over by a slot (model activations).", static_cast<double>(m.swaps));
  gauge("panelbass_in_fault", "1 while the chain is in its safe bypass.", m.in_fault ? 1.0 : 0.0);
  gauge("panelbass_load", "Processing time over audio time.", m.load);
  gauge("panelbass_max_late_seconds", "Most a paced block was behind its schedule.", m.max_late_ns * 1e-9);
  gauge("panelbass_peak_drive", "Largest |drive| sent to the amplifier (never above 1).", m.peak_drive);
  gauge("panelbass_peak_demand", "Largest |drive| the chain asked for before the limiter (above 1: more than full scale).",
        m.peak_demand);
  counter("panelbass_limited_samples_total", "Samples the safety limiter compressed (drive asked for above its knee).",
          static_cast<double>(m.limited_samples));
  counter("panelbass_over_range_samples_total",
          "Samples whose drive asked for was at or beyond full scale (the program needs more drive than the chain allows).",
          static_cast<double>(m.over_range_samples));
  e.family("panelbass_block_seconds", "summary", "Processing time of an audio block.");
  e.sample("panelbass_block_seconds", "quantile=\"0.5\"", m.p50_block_ns * 1e-9);
  e.sample("panelbass_block_seconds", "quantile=\"0.99\"", m.p99_block_ns * 1e-9);
  e.sample("panelbass_block_seconds_sum", "", m.mean_block_ns * 1e-9 * static_cast<double>(m.blocks));
  e.sample("panelbass_block_seconds_count", "", static_cast<double>(m.blocks));
  // A family of its own: a summary has only quantiles, _sum and _count.
  gauge("panelbass_block_seconds_max", "Longest processing time of an audio block.", m.max_block_ns * 1e-9);
  if (service.device) {
    const engine::AlsaStatus& d = *service.device;
    gauge("panelbass_device_up", "1 while the sound card streams.", d.state == engine::AlsaState::running ? 1.0 : 0.0);
    counter("panelbass_device_losses_total", "Times a streaming sound card was lost.", static_cast<double>(d.losses));
    counter("panelbass_device_reopens_total", "Times a lost sound card came back.", static_cast<double>(d.reopens()));
    counter("panelbass_device_failed_opens_total", "Attempts to open the sound card that failed.",
            static_cast<double>(d.failed_opens));
  }
  gauge("panelbass_models_stored", "Models in the store.", static_cast<double>(service.models_stored));
  e.family("panelbass_jobs", "gauge", "Jobs by state.");
  for (const auto& [state, n] : service.jobs_by_state) {
    e.sample("panelbass_jobs", "state=\"" + state + "\"", static_cast<double>(n));
  }
  e.family("panelbass_http_requests_total", "counter", "HTTP responses sent, by status code.");
  for (const auto& [status, n] : service.responses_by_status) {
    e.sample("panelbass_http_requests_total", "code=\"" + std::to_string(status) + "\"", static_cast<double>(n));
  }
  return e.text();
}

}  // namespace panelbass::api
