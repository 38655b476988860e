#include "api/record_upload.h"

#include <unistd.h>

#include <algorithm>
#include <cctype>
#include <cerrno>
#include <cmath>
#include <cstdint>
#include <cstdio>
#include <cstring>
#include <system_error>
#include <vector>

#include "api/request_body.h"
#include "dsp/data_error.h"
#include "dsp/data_file.h"
#include "dsp/sample_rate.h"

namespace panelbass::api {
namespace {

// A rate as people write it: "48000", "44100.5".
std::string hertz_text(double fs) {
  char text[32];
  std::snprintf(text, sizeof text, "%.10g", fs);
  return text;
}

// The media type of a Content-Type header, lower case, without parameters ("text/csv; charset=utf-8" → "text/csv").
std::string media_type(std::string_view content_type) {
  std::string type(content_type.substr(0, content_type.find(';')));
  type.erase(std::remove_if(type.begin(), type.end(), [](unsigned char c) { return std::isspace(c); }), type.end());
  std::transform(type.begin(), type.end(), type.begin(), [](unsigned char c) { return std::tolower(c); });
  return type;
}

// The sizes a RIFF (or RIFX) WAV's header claims against the bytes sent: the form's size and every chunk's up
// to the data chunk must fit in the body (a truncated file, or a data size of 0xFFFFFFFE, which readers
// would otherwise take as "read what is there"). HttpError 400 naming the chunk and both sizes. RF64 keeps
// its sizes elsewhere (ds64) and is left to the reader.
void check_wav_sizes(std::string_view body) {
  const bool big_endian = body.substr(0, 4) == "RIFX";
  if (!big_endian && body.substr(0, 4) != "RIFF") return;
  if (body.size() < 12) {
    throw HttpError{400, "bad_request", "body: a WAV header is 12 bytes (RIFF, its size, WAVE), the body has " +
                                            std::to_string(body.size())};
  }
  const auto u32 = [&](std::size_t at) -> std::uint64_t {
    std::uint64_t v = 0;
    for (int k = 0; k < 4; ++k) {
      const auto b = static_cast<std::uint64_t>(static_cast<unsigned char>(body[at + static_cast<std::size_t>(k)]));
      v |= b << (8 * (big_endian ? 3 - k : k));
    }
    return v;
  };
  const auto u16 = [&](std::size_t at) -> std::uint64_t {
    const auto lo = static_cast<unsigned char>(body[at + (big_endian ? 1 : 0)]);
    const auto hi = static_cast<unsigned char>(body[at + (big_endian ? 0 : 1)]);
    return static_cast<std::uint64_t>(lo) | (static_cast<std::uint64_t>(hi) << 8);
  };
  const std::uint64_t form = u32(4) + 8;
  if (form > body.size()) {
    throw HttpError{400, "bad_request", "body: the WAV header says the file has " + std::to_string(form) +
                                            " bytes (RIFF size), the body has " + std::to_string(body.size()) +
                                            " (a truncated file?)"};
  }
  std::uint64_t frame_bytes = 0;
  for (std::size_t at = 12; at + 8 <= body.size();) {
    const std::string id(body.substr(at, 4));
    const std::uint64_t size = u32(at + 4);
    const std::uint64_t present = body.size() - (at + 8);
    if (id == "fmt " && size >= 16 && size <= present) frame_bytes = u16(at + 8 + 12);
    if (size > present) {
      const auto frames = [&](std::uint64_t bytes) {
        return frame_bytes > 0 ? " (" + std::to_string(bytes / frame_bytes) + " frames)" : std::string();
      };
      throw HttpError{400, "bad_request", "body: the WAV's \"" + id + "\" chunk says " + std::to_string(size) +
                                              " bytes" + (id == "data" ? frames(size) : "") + ", the file holds " +
                                              std::to_string(present) + (id == "data" ? frames(present) : "") +
                                              " after its header (a truncated file?)"};
    }
    if (id == "data") return;
    at += 8 + static_cast<std::size_t>(size) + static_cast<std::size_t>(size & 1);
  }
}

// RIFF (little-endian), RIFX (big-endian) or RF64 (over 4 GiB), then the WAVE form type at byte 8.
bool looks_like_wav(std::string_view body) {
  if (body.size() < 12 || body.substr(8, 4) != "WAVE") return false;
  const std::string_view tag = body.substr(0, 4);
  return tag == "RIFF" || tag == "RIFX" || tag == "RF64";
}

// Text (no NUL or other control bytes but tab, CR and LF in the first 4 KiB) whose first line has a comma, and
// not JSON (a first character '{' or '[').
bool looks_like_csv(std::string_view body) {
  const std::string_view head = body.substr(0, 4096);
  const std::size_t first = head.find_first_not_of(" \t\r\n");
  if (first != std::string_view::npos && (head[first] == '{' || head[first] == '[')) return false;
  for (const char ch : head) {
    const auto c = static_cast<unsigned char>(ch);
    if (c < 0x20 && c != '\t' && c != '\r' && c != '\n') return false;
  }
  const std::string_view first_line = head.substr(0, head.find('\n'));
  return first_line.find(',') != std::string_view::npos;
}

// The body in a scratch file beside the store (dsp's readers read paths), removed when this goes.
class ScratchFile {
 public:
  ScratchFile(const std::filesystem::path& folder, std::string_view body, const char* extension) {
    std::string pattern = (folder / ".upload.tmp-XXXXXX").string() + extension;
    const int fd = ::mkstemps(pattern.data(), static_cast<int>(std::strlen(extension)));
    if (fd < 0) {
      throw HttpError{507, "storage", "cannot write a scratch file in " + folder.string() + ": " + std::strerror(errno)};
    }
    path_ = pattern;
    std::size_t written = 0;
    while (written < body.size()) {
      const ssize_t n = ::write(fd, body.data() + written, body.size() - written);
      if (n < 0 && errno == EINTR) continue;
      if (n <= 0) {
        const int error = errno;
        ::close(fd);
        throw HttpError{507, "storage", "cannot write a scratch file in " + folder.string() + ": " + std::strerror(error)};
      }
      written += static_cast<std::size_t>(n);
    }
    ::close(fd);
  }
  ~ScratchFile() {
    std::error_code ignored;
    std::filesystem::remove(path_, ignored);
  }
  ScratchFile(const ScratchFile&) = delete;
  ScratchFile& operator=(const ScratchFile&) = delete;
  const std::filesystem::path& path() const { return path_; }

 private:
  std::filesystem::path path_;
};

// `message` with every mention of the scratch file's path replaced by "body".
std::string about_body(std::string message, const std::string& path) {
  for (std::size_t at = message.find(path); at != std::string::npos; at = message.find(path, at + 4)) {
    message.replace(at, path.size(), "body");
  }
  return message;
}

}  // namespace

const char* upload_format_name(UploadFormat format) { return format == UploadFormat::wav ? "wav" : "csv"; }

UploadFormat upload_format(std::string_view body, std::string_view content_type) {
  const std::string type = media_type(content_type);
  if (type == "audio/wav" || type == "audio/x-wav" || type == "audio/wave" || type == "audio/vnd.wave" ||
      type == "audio/x-wave") {
    return UploadFormat::wav;
  }
  if (type == "text/csv" || type == "application/csv" || type == "text/comma-separated-values") return UploadFormat::csv;
  if (looks_like_wav(body)) return UploadFormat::wav;
  if (looks_like_csv(body)) return UploadFormat::csv;
  throw HttpError{415, "unsupported_media_type",
                  "body: neither a WAV file (it would start with RIFF…WAVE) nor CSV text with a header row (a comma "
                  "in its first line); send the file itself (curl --data-binary @rec.wav, or -H 'Content-Type: text/csv')"};
}

dsp::Record read_uploaded_record(std::string_view body, const RecordUpload& upload, double engine_fs,
                                 const std::filesystem::path& scratch_folder) {
  if (body.empty()) {
    throw HttpError{400, "bad_request", "body: missing; POST /api/records takes the WAV or CSV file itself as the body"};
  }
  const UploadFormat format = upload_format(body, upload.content_type);
  if (format == UploadFormat::csv && !(upload.fs > 0.0)) {
    throw HttpError{400, "bad_request", "fs: required for a CSV upload (the file does not say its rate); the engine "
                                        "runs at " + hertz_text(engine_fs) + " Hz"};
  }
  std::vector<std::string> channels = {upload.input, upload.output};
  if (!upload.current.empty()) channels.push_back(upload.current);
  for (std::size_t a = 0; a < channels.size(); ++a) {
    if (channels[a].empty()) throw HttpError{400, "bad_request", std::string(a == 0 ? "input" : "output") + ": empty"};
    for (std::size_t b = 0; b < a; ++b) {
      if (channels[a] == channels[b]) {
        throw HttpError{400, "bad_request", "channel \"" + channels[a] + "\" is named twice (input, output and current "
                                            "must be different channels)"};
      }
    }
  }
  if (format == UploadFormat::wav) check_wav_sizes(body);
  const ScratchFile scratch(scratch_folder, body, format == UploadFormat::wav ? ".wav" : ".csv");
  dsp::Record record;
  try {
    record = dsp::read_data_file(scratch.path(), channels, upload.fs, kMinRecordSamples);
  } catch (const dsp::DataError& e) {
    throw HttpError{400, "bad_request", about_body(e.what(), scratch.path().string())};
  }
  if (!dsp::same_rate(record.fs, engine_fs)) {
    throw HttpError{400, "bad_request", "fs: the record is at " + hertz_text(record.fs) + " Hz, the engine runs at " +
                                            hertz_text(engine_fs) + " Hz (resample it first)"};
  }
  if (record.samples() > kMaxRecordSamples) {
    throw HttpError{413, "too_large", "body: " + std::to_string(record.samples()) + " samples, more than the " +
                                          std::to_string(kMaxRecordSamples) + " a record may have"};
  }
  // dsp's readers refuse non-finite samples and ragged rows; this is the contract, checked once more.
  for (const Eigen::VectorXd& column : record.columns) {
    if (!column.allFinite()) throw HttpError{400, "bad_request", "body: a sample is not finite"};
  }
  dsp::Record out;
  out.fs = engine_fs;
  out.add("u", record.columns[0]);
  out.add("y", record.columns[1]);
  if (!upload.current.empty()) out.add("i", record.columns[2]);
  return out;
}

}  // namespace panelbass::api
