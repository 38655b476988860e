#pragma once
// The record an excite job leaves behind (estimation and validation parts of drive and response, and a
// control excitation's harmonic weights), read back for the jobs that use it, and the part of it a model is
// judged on.

#include <Eigen/Core>
#include <nlohmann/json.hpp>
#include <string>
#include <vector>

#include "usecases/excite.h"
#include "usecases/transducer_port.h"

namespace panelbass::api {

class RecordStore;

/// The estimation and validation parts of a recording (usecases/excite.h).
using ExcitationRecord = usecases::ExcitationRecord;

/// What playing a drive through a sound card gave (usecases/card_measurement.h): the sensor, the current and the
/// loopback aligned to the drive (empty when not captured), and what the calibration measured in `report`.
using MeasuredResponse = usecases::Playback;

/// {"u_est":[…],"y_est":[…],"u_val":[…],"y_val":[…]}, "w_est", "w_val" when the record has weights, and
/// "i_est", "i_val" when it has the current, "l_est", "l_val" when it has the converters' output.
nlohmann::json excitation_record_to_json(const ExcitationRecord& record);

/// The record as one CSV file for the record store: columns u, y and, when the record has them, i, w and l; the
/// estimation rows first, then the validation rows; every number to 17 significant digits (read back exactly).
std::string excitation_record_csv(const ExcitationRecord& record);

/// The columns excitation_record_csv writes for `record` ("u", "y", then "i", "w", "l" where present).
std::vector<std::string> excitation_record_columns(const ExcitationRecord& record);

/// The record in an excite job's result, checked: {"fs", "record":{…}} (inline, as jobs kept it before), or
/// {"fs", "record_id":"r…", "record_columns":[…], "samples"} (kept once in `records`, the record store). Four arrays
/// of finite numbers, equal lengths per part, at least 200 estimation samples, recorded at `fs`. Throws
/// std::invalid_argument starting with `where` ("params.record: job j3 …").
ExcitationRecord excitation_record_from_result(const nlohmann::json& result, double fs, const std::string& where,
                                               const RecordStore* records = nullptr);

/// The fewest samples a record part must have.
inline constexpr long long kMinSamples = usecases::kMinRecordSamples;
/// The most samples a record part may have.
inline constexpr long long kMaxSamples = usecases::kMaxRecordSamples;

/// The part of a record a model is judged on: validation when there is one, else estimation.
struct JudgedPart {
  const Eigen::VectorXd& u;  ///< raw drive
  const Eigen::VectorXd& y;  ///< raw response
  bool validation;           ///< true for the validation part
};

/// The validation part of `r` when it has one, else its estimation part (refers into `r`).
JudgedPart judged_part(const ExcitationRecord& r);

}  // namespace panelbass::api
