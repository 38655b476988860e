// EngineService::measure: the card measurement protocol (usecases/card_measurement.h) through the service's card,
// a card that cannot be measured through refused as a conflict.
#include "api/engine_service.h"
#include "usecases/card_measurement.h"

namespace panelbass::api {

MeasuredResponse EngineService::measure(const Eigen::VectorXd& drive) {
  if (!alsa_) throw EngineRequestError(409, "conflict", "measure: this server plays on the virtual transducer");
  if (const std::optional<std::string> why = usecases::card_cannot_measure(*options_.alsa)) {
    throw EngineRequestError(409, "conflict", "excite: " + *why);
  }
  return usecases::measure_through_card(*alsa_, *options_.alsa,
                                        {options_.chain.fs, options_.safe_level, options_.measurement_fade_s}, drive);
}

}  // namespace panelbass::api
