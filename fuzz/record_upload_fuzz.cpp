// libFuzzer target: the body of POST /api/records (api/record_upload.h read_uploaded_record: the format told
// from the content type or the first bytes, then dsp's WAV or CSV reader on a scratch file, then the checks of
// rate, length and finiteness). The first input byte chooses the request's content type, fs and channels; the
// rest is the body. A bad body must be an HttpError (400, 413, 415) naming what is wrong, never a crash, a
// hang or any other exception.
#include <cstddef>
#include <cstdint>
#include <cstdlib>
#include <filesystem>
#include <string>
#include <string_view>
#include <system_error>

#include "api/record_upload.h"
#include "api/request_body.h"
#include "fuzz/scratch_file.h"

namespace {

namespace fs = std::filesystem;

/// The folder the upload's scratch files go to, one per process.
const fs::path& scratch_folder() {
  static const fs::path folder = [] {
    const fs::path dir = panelbass::fuzz::scratch_file("record-upload-fuzz", "");
    std::error_code ignored;
    fs::create_directories(dir, ignored);
    std::atexit([] {
      std::error_code ignored_too;
      fs::remove_all(scratch_folder(), ignored_too);
    });
    return dir;
  }();
  return folder;
}

}  // namespace

extern "C" int LLVMFuzzerTestOneInput(const std::uint8_t* data, std::size_t size) {
  if (size == 0) return 0;
  const std::uint8_t choice = data[0];
  const std::string_view body(reinterpret_cast<const char*>(data + 1), size - 1);
  panelbass::api::RecordUpload upload;
  static const char* const kTypes[] = {"", "audio/wav", "text/csv; charset=utf-8", "application/octet-stream"};
  upload.content_type = kTypes[choice & 3];
  upload.fs = (choice & 4) != 0 ? 3000.0 : 0.0;
  const bool by_index = (choice & 8) != 0;
  upload.input = by_index ? "0" : "u";
  upload.output = by_index ? "1" : "y";
  if ((choice & 16) != 0) upload.current = by_index ? "2" : "i";
  try {
    (void)panelbass::api::read_uploaded_record(body, upload, 3000.0, scratch_folder());
  } catch (const panelbass::api::HttpError& e) {
    if (e.message.empty() || (e.status != 400 && e.status != 413 && e.status != 415)) std::abort();
  }
  return 0;
}
