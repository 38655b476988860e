#pragma once
// The verbs of the `panelbass` command. Each registers a CLI11 subcommand whose callback prints one
// JSON object (the result) on stdout; progress goes to stderr; errors propagate as exceptions.

#include <CLI/CLI.hpp>

namespace panelbass::cli {

/// `panelbass simulate`: drive the virtual transducer with an excitation and write the record.
void register_simulate(CLI::App& app);

/// `panelbass identify linear`: identify a model from measured data.
void register_identify(CLI::App& app);

/// `panelbass validate`: judge a model on data by simulation and prediction.
void register_validate(CLI::App& app);

/// `panelbass harmonics`: stepped-sine harmonic distortion of a plant, and of a model beside it.
void register_harmonics(CLI::App& app);

/// `panelbass plant show|survey`: print a plant's configuration, or measure its properties.
void register_plant(CLI::App& app);

/// `panelbass analyze`: the Analysis report of a model on data (JSON, figures, HTML).
void register_analyze(CLI::App& app);

}  // namespace panelbass::cli
