// panelbass: identify panel transducers and cancel their distortion.
// Exit status: 0 ok, 1 failed (bad data, bad file, failed computation), 2 bad usage.

#include <CLI/CLI.hpp>
#include <exception>
#include <iostream>

#include "cli/commands.h"

int main(int argc, char** argv) {
  CLI::App app{"panelbass: identify panel-mounted transducers and cancel their distortion", "panelbass"};
  app.require_subcommand(1);
  app.set_version_flag("--version", "panelbass 0.1.0");
  app.set_config("--config", "", "Read options from this file (before the verb): a [verb] section of key = value lines");
  app.footer("Run `panelbass <verb> --help` for a verb's options and an example.");
  panelbass::cli::register_simulate(app);
  panelbass::cli::register_plant(app);
  panelbass::cli::register_identify(app);
  panelbass::cli::register_validate(app);
  panelbass::cli::register_harmonics(app);
  panelbass::cli::register_analyze(app);
  panelbass::cli::register_render(app);
  panelbass::cli::register_run(app);
  panelbass::cli::register_design(app);
  panelbass::cli::register_chain(app);
  panelbass::cli::register_evaluate(app);
  panelbass::cli::register_tune(app);
  panelbass::cli::register_measure(app);
  panelbass::cli::register_verify(app);
  panelbass::cli::register_diagnose(app);
  panelbass::cli::register_serve(app);
  panelbass::cli::register_transducer(app);

  try {
    app.parse(argc, argv);
  } catch (const CLI::ParseError& e) {
    const int rc = app.exit(e);
    return rc == 0 ? 0 : 2;
  } catch (const std::exception& e) {
    std::cerr << "panelbass: error: " << e.what() << std::endl;
    return 1;
  }
  return 0;
}
