#include "evaluation/evaluation_json.h"

#include "models/io/json_fields.h"

namespace panelbass::evaluation {

nlohmann::json evaluation_row_to_json(const EvaluationRow& row) {
  nlohmann::json probes = nlohmann::json::array();
  for (const ProbeResult& p : row.probes) {
    nlohmann::json harmonics = nlohmann::json::array();  // H2..Hn; null for a harmonic that is exactly zero
    for (double db : p.harmonics_db) harmonics.push_back(models::number_or_null(db));
    probes.push_back({{"frequency_hz", p.frequency_hz},
                      {"amplitude", p.amplitude},
                      {"drive_peak", p.drive_peak},
                      {"h2_db", p.h2_db},
                      {"h3_db", p.h3_db},
                      {"thd_pct", p.thd_pct},
                      {"harmonics_db", harmonics},
                      {"model_thd_pct", models::number_or_null(p.model_thd_pct)}});
  }
  return {{"name", row.name},
          {"ripple_db", row.ripple_db},
          {"jc_pct", row.jc_pct},
          {"measured_ripple_db", row.measured_ripple_db},
          {"measured_jc_pct", row.measured_jc_pct},
          {"max_drive", row.max_drive},
          {"rail_fraction", row.rail_fraction},
          {"rest_drive_peak", row.rest_drive_peak},
          {"faults", row.faults},
          {"probes", probes}};
}

nlohmann::json attribution_to_json(const std::vector<TermDistortion>& terms) {
  nlohmann::json attribution = nlohmann::json::array();
  for (const TermDistortion& t : terms) {
    nlohmann::json rows = nlohmann::json::array();
    for (const EvaluationRow& row : t.rows) rows.push_back(evaluation_row_to_json(row));
    attribution.push_back({{"term", t.term}, {"rows", rows}});
  }
  return attribution;
}

namespace {

nlohmann::json harmonic_figures_to_json(const HarmonicFigures& h) {
  return {{"fundamental", models::number_or_null(h.fundamental)},
          {"thd_pct", models::number_or_null(h.thd_pct)},
          {"h2_db", models::number_or_null(h.h2_db)},
          {"h3_db", models::number_or_null(h.h3_db)},
          {"drive_peak", models::number_or_null(h.drive_peak)}};
}

}  // namespace

nlohmann::json level_sweep_to_json(const LevelSweep& sweep) {
  nlohmann::json curves = nlohmann::json::array();
  for (const LevelCurve& c : sweep.curves) {
    nlohmann::json points = nlohmann::json::array();
    for (const LevelPoint& p : c.points) {
      points.push_back({{"program_amplitude", p.program_amplitude},
                        {"reachable", p.reachable},
                        {"needs_more_drive", p.needs_more_drive},
                        {"peak_demand", models::number_or_null(p.peak_demand)},
                        {"cut_db", models::number_or_null(p.cut_db)},
                        {"noise_floor_pct", models::number_or_null(p.noise_floor_pct)},
                        {"plant_drive", models::number_or_null(p.plant_drive)},
                        {"chain", harmonic_figures_to_json(p.chain)},
                        {"plant", harmonic_figures_to_json(p.plant)}});
    }
    curves.push_back({{"frequency_hz", c.frequency_hz},
                      {"worst_cut_db", models::number_or_null(sweep.worst_cut_db(c.frequency_hz))},
                      {"points", points}});
  }
  nlohmann::json imd = nlohmann::json::array();
  for (const ImdPoint& p : sweep.imd) {
    imd.push_back({{"program_amplitude", p.program_amplitude},
                   {"output_low", models::number_or_null(p.output_low)},
                   {"chain_imd_pct", models::number_or_null(p.chain_imd_pct)},
                   {"plant_scale", models::number_or_null(p.plant_scale)},
                   {"plant_imd_pct", models::number_or_null(p.plant_imd_pct)},
                   {"cut_db", models::number_or_null(p.cut_db)},
                   {"reachable", p.reachable}});
  }
  return {{"curves", curves}, {"imd", imd}};
}

}  // namespace panelbass::evaluation
