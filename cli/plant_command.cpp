#include <cstdint>
#include <memory>
#include <string>

#include "cli/commands.h"
#include "cli/json_output.h"
#include "cli/usecase_door.h"
#include "models/plant/plant_presets.h"
#include "models/plant/plant_variants.h"
#include "usecases/plant_survey.h"

namespace panelbass::cli {

void register_plant(CLI::App& app) {
  CLI::App* plant = app.add_subcommand("plant", "Show or survey a virtual transducer");
  plant->require_subcommand(1);
  plant->footer("Examples:\n  panelbass plant show panel-exciter > my-plant.json\n  panelbass plant survey my-plant.json\n"
                "  panelbass plant vary panel-exciter --by 0.2 --seed 3 > variant.json");

  auto name = std::make_shared<std::string>();
  CLI::App* show = plant->add_subcommand("show", "Print a plant's full configuration as JSON");
  show->add_option("plant", *name, "Preset (panel-exciter, linear) or plant JSON file")->required();
  show->footer("Example:\n  panelbass plant show panel-exciter");
  show->callback([name] { print_result(models::plant_to_json(models::plant_from_name_or_file(*name))); });

  auto vary_name = std::make_shared<std::string>();
  auto fraction = std::make_shared<double>(0.2);
  auto vary_seed = std::make_shared<std::uint64_t>(1);
  CLI::App* vary = plant->add_subcommand(
      "vary", "Print a variant of a plant: Bl, K, Le and friction each moved by ±FRACTION, in mixed directions from a seed");
  vary->add_option("plant", *vary_name, "Preset (panel-exciter, linear) or plant JSON file")->required();
  vary->add_option("--by", *fraction, "How far each parameter moves (0.2: ±20 %)")->check(CLI::Range(1e-6, 0.9))->capture_default_str();
  vary->add_option("--seed", *vary_seed, "Seed of the directions")->capture_default_str();
  vary->footer("Example:\n  panelbass plant vary panel-exciter --by 0.2 --seed 3 > variant.json");
  vary->callback([vary_name, fraction, vary_seed] {
    print_result(models::plant_to_json(models::varied_plant(models::plant_from_name_or_file(*vary_name), *fraction, *vary_seed)));
  });

  auto survey_name = std::make_shared<std::string>();
  auto survey_request = std::make_shared<usecases::PlantSurveyRequest>();
  CLI::App* survey = plant->add_subcommand(
      "survey", "Measure a plant from simulated data: delay, impulse length, resonances, notch, J, distortion");
  survey->add_option("plant", *survey_name, "Preset (panel-exciter, linear) or plant JSON file")->required();
  survey->add_option("--seed", survey_request->seed, "Seed of the excitations and the noise")->capture_default_str();
  survey->add_option("--samples", survey_request->samples, "Estimation samples of uniform noise (1000..10000000)")
      ->capture_default_str();
  survey->add_option("--amplitude", survey_request->amplitude, "Peak drive of the noise, (0, 1]")->capture_default_str();
  survey->footer("Example:\n  panelbass plant survey panel-exciter --seed 1");
  survey->callback([survey_name, survey_request] {
    usecases::PlantSurveyRequest q = *survey_request;
    q.plant = models::plant_from_name_or_file(*survey_name);
    usecases::SilentProgress quiet;
    print_result(run_use_case([&] { return usecases::survey_plant(q, quiet); }).summary);
  });
}

}  // namespace panelbass::cli
