#pragma once
// The verbs of the `panelbass` command. Each registers a CLI11 subcommand whose callback prints one
// JSON object (the result) on stdout; progress goes to stderr; errors propagate as exceptions.

#include <CLI/CLI.hpp>

namespace panelbass::cli {

/// `panelbass simulate`: drive the virtual transducer with an excitation and write the record.
void register_simulate(CLI::App& app);

/// `panelbass identify linear`: identify a model from measured data.
void register_identify(CLI::App& app);
/// `identify ss` under `identify`.
void register_identify_ss(CLI::App& identify);
/// `identify oscillator` under `identify`.
void register_identify_oscillator(CLI::App& identify);
/// `identify average` under `identify`.
void register_identify_average(CLI::App& identify);
/// `identify mimo` under `identify`.
void register_identify_mimo(CLI::App& identify);

/// `panelbass validate`: judge a model on data by simulation and prediction.
void register_validate(CLI::App& app);

/// `panelbass harmonics`: stepped-sine harmonic distortion of a plant, and of a model beside it.
void register_harmonics(CLI::App& app);

/// `panelbass plant show|survey`: print a plant's configuration, or measure its properties.
void register_plant(CLI::App& app);

/// `panelbass analyze`: the Analysis report of a model on data (JSON, figures, HTML).
void register_analyze(CLI::App& app);

/// `panelbass render`: a WAV file through a chain file offline; with a plant, the transducer's output too.
void register_render(CLI::App& app);

/// `panelbass run`: a chain file on a live backend (virtual or ALSA) until interrupted; prints the metrics.
void register_run(CLI::App& app);

/// `panelbass design lq`: design a controller on an identified model (LQ feedforward, thesis ch. 7).
void register_design(CLI::App& app);

/// Adds `design nn` (the neural feedback controller) to the `design` verb `design`.
void add_design_nn(CLI::App& design);

/// Adds `design mirror` (the mirror filter fitted to a record) to the `design` verb `design`.
void add_design_mirror(CLI::App& design);

/// `panelbass chain`: write the chain file the engine runs (band-pass, feedforward, feedback).
void register_chain(CLI::App& app);

/// `panelbass evaluate`: a chain on a simulated transducer — response ripple, THD and J_c per configuration.
void register_evaluate(CLI::App& app);

/// `panelbass diagnose`: locate where a simulation and a recording disagree, name the physics left out, model it.
void register_diagnose(CLI::App& app);

/// `panelbass tune`: measure, fit from the current, mirror filter, verify at equal output, keep where it helps.
void register_tune(CLI::App& app);

/// `panelbass measure`: a record measured through a backend (virtual or a sound card), written as CSV.
void register_measure(CLI::App& app);

/// `panelbass verify`: controllers verified through a backend at equal output level.
void register_verify(CLI::App& app);

/// `panelbass serve`: the engine, the HTTP API and the web UI in one process.
void register_serve(CLI::App& app);

/// `panelbass transducer --jack`: the virtual transducer as a JACK client (drive in, sensor and current out).
void register_transducer(CLI::App& app);

}  // namespace panelbass::cli
