#include "api/jobs/backend_play.h"

#include <atomic>
#include <memory>
#include <stdexcept>

#include "models/plant/virtual_transducer.h"

namespace panelbass::api {

usecases::PlayFunction backend_play(const JobEnvironment& env, PlayedChannels channels, std::uint64_t seed) {
  auto next_seed = std::make_shared<std::atomic<std::uint64_t>>(seed);
  return [&env, channels, next_seed](const Eigen::VectorXd& drive) {
    usecases::Playback out;
    if (env.measure) {
      out = env.measure(drive);
    } else if (channels == PlayedChannels::sensor_and_current && env.plant) {
      models::PlantRecord r = models::simulate(*env.plant, drive, next_seed->fetch_add(1));
      out.sensor = std::move(r.y);
      out.current = std::move(r.i);
    } else if (env.excite) {
      out.sensor = env.excite(drive);
    } else {
      throw std::runtime_error("this server has no backend to play through");
    }
    return out;
  };
}

}  // namespace panelbass::api
