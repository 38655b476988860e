#pragma once
// An uploaded recording (POST /api/records): the file itself as the body — a WAV (any PCM or float format) or
// a CSV with a header row, told apart by the content type or the file's first bytes — read through dsp's own
// readers and checked (finite, equal lengths, the engine's rate, a minimum and a maximum length).

#include <filesystem>
#include <string>
#include <string_view>

#include "api/jobs/excitation_record.h"
#include "dsp/record.h"

namespace panelbass::api {

/// The kind of data file an upload carries.
enum class UploadFormat { wav, csv };

/// "wav" or "csv".
const char* upload_format_name(UploadFormat format);

/// What an upload request says besides its body.
struct RecordUpload {
  std::string content_type;       ///< the request's Content-Type ("" when none)
  double fs = 0.0;                ///< the query's fs, Hz; 0 when not given (a WAV file says its own)
  std::string input = "u";        ///< drive channel: a WAV channel index or name, a CSV column
  std::string output = "y";       ///< response channel
  std::string current;            ///< current channel; "" when none
};

/// The fewest samples an uploaded record may have: two record parts (estimation and validation) of kMinSamples.
inline constexpr std::size_t kMinRecordSamples = 2 * kMinSamples;
/// The most samples an uploaded record may have (as many as an excite job's part).
inline constexpr std::size_t kMaxRecordSamples = kMaxSamples;

/// The format of `body`: by `content_type` when it names WAV (audio/wav, audio/x-wav, audio/wave,
/// audio/vnd.wave) or CSV (text/csv, application/csv), else by its first bytes (RIFF/RF64…WAVE, or text
/// with a comma in its first line). Throws HttpError 415 "unsupported_media_type" when it is neither.
UploadFormat upload_format(std::string_view body, std::string_view content_type);

/// Reads and checks the record in `body`: columns "u", "y" and, when a current channel is named, "i", at
/// `engine_fs` (record.fs). The body is written to a scratch file in `scratch_folder` (named ".upload.tmp-…",
/// removed before returning) for dsp's readers. Throws HttpError: 415 (not WAV/CSV), 413 "too_large" (more
/// than kMaxRecordSamples), 400 "bad_request" naming the channel, line or rate otherwise ("body:12: column
/// \"y\": not a number", "fs: the record is at 48000 Hz, the engine runs at 3000 Hz").
dsp::Record read_uploaded_record(std::string_view body, const RecordUpload& upload, double engine_fs,
                                 const std::filesystem::path& scratch_folder);

}  // namespace panelbass::api
