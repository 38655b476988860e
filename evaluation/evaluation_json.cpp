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

}  // namespace panelbass::evaluation
