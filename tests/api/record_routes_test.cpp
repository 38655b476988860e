// Uploaded recordings (ROUTES.md "Records"): POST/GET/DELETE /api/records on the real server, a test per
// bad-input class (each leaving nothing stored), and an identification from an uploaded record.
#include <gtest/gtest.h>

#include <charconv>
#include <cmath>
#include <fstream>
#include <limits>
#include <string>

#include "api/jobs/model_judgement.h"
#include "dsp/excitation.h"
#include "dsp/wav_file.h"
#include "tests/api/server_fixture.h"

namespace panelbass::api {
namespace {

using namespace api_testing;
using nlohmann::json;

constexpr double kFs = 3000.0;  // the panel-exciter preset's rate, the engine's in ServerTest

// `x` as the shortest text that reads back to the same double.
std::string text_of(double x) {
  char buffer[32];
  const auto end = std::to_chars(buffer, buffer + sizeof buffer, x).ptr;
  return std::string(buffer, end);
}

// A drive u (uniform noise, peak 0.5, seed 3) and y(k) = 0.5·u(k) − 0.25·u(k−1) + 0.125·u(k−2) (rest before k = 0):
// a record whose FIR model of order 3 is exact.
struct FirRecord {
  Eigen::VectorXd u, y;
};
FirRecord fir_record(Eigen::Index n) {
  FirRecord r;
  r.u = dsp::uniform_noise(static_cast<std::size_t>(n), 0.5, 3);
  r.y = Eigen::VectorXd::Zero(n);
  for (Eigen::Index k = 0; k < n; ++k) {
    r.y[k] = 0.5 * r.u[k] - (k >= 1 ? 0.25 * r.u[k - 1] : 0.0) + (k >= 2 ? 0.125 * r.u[k - 2] : 0.0);
  }
  return r;
}

// CSV text with a header row "u,y" (and "i" = u/4 when `current`).
std::string csv_of(const FirRecord& r, bool current = false) {
  std::string text = current ? "u,y,i\n" : "u,y\n";
  for (Eigen::Index k = 0; k < r.u.size(); ++k) {
    text += text_of(r.u[k]) + "," + text_of(r.y[k]) + (current ? "," + text_of(r.u[k] / 4.0) : "") + "\n";
  }
  return text;
}

class RecordRoutesTest : public ServerTest {
 protected:
  /// POST `body` to /api/records`query` with `type` as its Content-Type.
  Reply upload_record(const std::string& query, const std::string& body, const std::string& type = "text/csv") {
    return reply_of(client_->Post(("/api/records" + query).c_str(), body, type.c_str()));
  }
  /// The files in the store's records folder.
  std::size_t stored_files() {
    std::size_t n = 0;
    for ([[maybe_unused]] const auto& entry : std::filesystem::directory_iterator(dir_ / "store" / "records")) ++n;
    return n;
  }
  /// The bytes of a file written by dsp::write_wav.
  std::string wav_bytes(const dsp::Record& record, dsp::WavFormat format) {
    const std::filesystem::path path = dir_ / "upload.wav";
    dsp::write_wav(path, record, format);
    std::ifstream in(path, std::ios::binary);
    return std::string(std::istreambuf_iterator<char>(in), {});
  }
  /// Expects `r` to be an error with `status` whose message contains `fragment`, and nothing stored.
  void expect_refused(const Reply& r, int status, const std::string& fragment) {
    EXPECT_EQ(r.status, status) << r.text;
    EXPECT_NE(error_message(r).find(fragment), std::string::npos) << error_message(r);
    EXPECT_EQ(get("/api/records").body["total"], 0);
    EXPECT_EQ(stored_files(), 0u);
  }
};

TEST_F(RecordRoutesTest, ACsvUploadIsStoredListedReadBackAndDeleted) {
  start();
  const FirRecord r = fir_record(1000);
  const Reply created = upload_record("?fs=3000&name=bench", csv_of(r));
  ASSERT_EQ(created.status, 201) << created.text;
  const std::string id = created.body["id"];
  EXPECT_TRUE(is_record_id(id)) << id;
  EXPECT_EQ(created.body["samples"], 1000);
  EXPECT_EQ(created.body["fs"], kFs);
  EXPECT_EQ(created.body["file"], "csv");
  EXPECT_EQ(created.body["name"], "bench");
  EXPECT_TRUE(created.body["current"].is_null());
  EXPECT_EQ(stored_files(), 2u);  // the file and its entry

  // The same file and channels: the same id, not stored twice; a new name renames it.
  const Reply again = upload_record("?fs=3000&name=panel", csv_of(r));
  EXPECT_EQ(again.status, 200) << again.text;
  EXPECT_EQ(again.body["id"], id);
  EXPECT_EQ(again.body["name"], "panel");

  const Reply one = get("/api/records/" + id);
  ASSERT_EQ(one.status, 200) << one.text;
  ASSERT_EQ(one.body["data"]["u"].size(), 1000u);
  // CSV at full precision reads back exactly.
  for (Eigen::Index k : {Eigen::Index{0}, Eigen::Index{517}, Eigen::Index{999}}) {
    EXPECT_EQ(one.body["data"]["u"][k].get<double>(), r.u[k]);
    EXPECT_EQ(one.body["data"]["y"][k].get<double>(), r.y[k]);
  }

  const Reply list = get("/api/records");
  ASSERT_EQ(list.status, 200);
  EXPECT_EQ(list.body["total"], 1);
  EXPECT_EQ(list.body["records"][0]["id"], id);

  EXPECT_EQ(del("/api/records/" + id).status, 204);
  EXPECT_EQ(get("/api/records/" + id).status, 404);
  EXPECT_EQ(del("/api/records/" + id).status, 404);
  EXPECT_EQ(stored_files(), 0u);
}

TEST_F(RecordRoutesTest, AWavUploadTakesItsRateAndNamedChannelsFromTheFile) {
  start();
  const FirRecord r = fir_record(600);
  dsp::Record rec;
  rec.fs = kFs;
  rec.add("y", r.y);
  rec.add("i", r.u / 4.0);
  rec.add("u", r.u);
  // Sniffed from its first bytes (application/octet-stream says nothing), channels by name and by index.
  const Reply created = upload_record("?current=1", wav_bytes(rec, dsp::WavFormat::float32), "application/octet-stream");
  ASSERT_EQ(created.status, 201) << created.text;
  EXPECT_EQ(created.body["file"], "wav");
  EXPECT_EQ(created.body["current"], "1");
  const Reply one = get("/api/records/" + created.body["id"].get<std::string>());
  ASSERT_EQ(one.status, 200) << one.text;
  for (Eigen::Index k : {Eigen::Index{0}, Eigen::Index{299}, Eigen::Index{599}}) {  // float32 in the file
    EXPECT_EQ(one.body["data"]["u"][k].get<double>(), static_cast<double>(static_cast<float>(r.u[k])));
    EXPECT_EQ(one.body["data"]["y"][k].get<double>(), static_cast<double>(static_cast<float>(r.y[k])));
    EXPECT_EQ(one.body["data"]["i"][k].get<double>(), static_cast<double>(static_cast<float>(r.u[k] / 4.0)));
  }
  // 16-bit PCM of the same record: another file, another id; samples within one step (2^-15) of the values.
  const Reply pcm = upload_record("?fs=3000&input=2&output=0", wav_bytes(rec, dsp::WavFormat::pcm16), "audio/wav");
  ASSERT_EQ(pcm.status, 201) << pcm.text;
  EXPECT_NE(pcm.body["id"], created.body["id"]);
  const Reply data = get("/api/records/" + pcm.body["id"].get<std::string>());
  EXPECT_NEAR(data.body["data"]["u"][10].get<double>(), r.u[10], std::ldexp(1.0, -15));
}

TEST_F(RecordRoutesTest, ListsArePagedOldestFirst) {
  start();
  std::vector<std::string> ids;
  for (int n = 0; n < 3; ++n) ids.push_back(upload_record("?fs=3000", csv_of(fir_record(400 + n))).body["id"]);
  const Reply page = get("/api/records?offset=1&limit=1");
  ASSERT_EQ(page.status, 200) << page.text;
  EXPECT_EQ(page.body["total"], 3);
  ASSERT_EQ(page.body["records"].size(), 1u);
  EXPECT_EQ(page.body["records"][0]["id"], ids[1]);
  EXPECT_EQ(get("/api/records?offset=5").body["records"].size(), 0u);
  EXPECT_EQ(get("/api/records?limit=x").status, 400);
}

TEST_F(RecordRoutesTest, AWavWhoseHeaderClaimsMoreThanItHoldsIsRefusedNamingBoth) {
  start();
  dsp::Record rec;
  rec.fs = kFs;
  const FirRecord r = fir_record(1000);
  rec.add("u", r.u);
  rec.add("y", r.y);
  const std::string whole = wav_bytes(rec, dsp::WavFormat::pcm16);
  // Two 16-bit channels: 4 bytes a frame, 1000 frames after the data chunk's 8-byte header.
  const std::size_t data = whole.find("data");
  ASSERT_NE(data, std::string::npos);
  ASSERT_EQ(whole.size(), data + 8 + 4000);
  // The file cut after 497 frames, its header left as it was (1000 frames).
  const std::string cut = whole.substr(0, data + 8 + 497 * 4);
  const Reply truncated = upload_record("", cut, "audio/wav");
  EXPECT_EQ(truncated.status, 400) << truncated.text;
  EXPECT_NE(error_message(truncated).find("the WAV header says the file has " + std::to_string(whole.size()) + " bytes"),
            std::string::npos) << error_message(truncated);
  // The form's size patched to fit: the data chunk's own claim is what is wrong.
  std::string patched = cut;
  const auto put_u32 = [](std::string& bytes, std::size_t at, std::uint32_t v) {
    for (int k = 0; k < 4; ++k) bytes[at + static_cast<std::size_t>(k)] = static_cast<char>((v >> (8 * k)) & 0xFF);
  };
  put_u32(patched, 4, static_cast<std::uint32_t>(patched.size() - 8));
  expect_refused(upload_record("", patched, "audio/wav"), 400, "\"data\" chunk says 4000 bytes (1000 frames), the file holds 1988 (497 frames)");
  // A data size of 0xFFFFFFFE ("read whatever is there") on a whole file.
  std::string huge = whole;
  put_u32(huge, data + 4, 0xFFFFFFFEu);
  expect_refused(upload_record("", huge, "audio/wav"), 400, "\"data\" chunk says 4294967294 bytes");
  // Shorter than a RIFF header (the fuzzer's find): named, not read past its end.
  for (const std::size_t n : {4u, 6u, 11u}) {
    expect_refused(upload_record("", whole.substr(0, n), "audio/wav"), 400,
                   "a WAV header is 12 bytes (RIFF, its size, WAVE), the body has " + std::to_string(n));
  }
  // The whole file is stored.
  EXPECT_EQ(upload_record("", whole, "audio/wav").status, 201);
}

TEST_F(RecordRoutesTest, ANameOrChannelThatIsNotUtf8TextIsABadRequest) {
  start();
  const FirRecord r = fir_record(1000);
  expect_refused(upload_record("?fs=3000&name=%FF%FE", csv_of(r)), 400, "name: not UTF-8 text (byte 0");
  expect_refused(upload_record("?fs=3000&name=a%0Ab", csv_of(r)), 400, "name: not UTF-8 text (byte 1 is a control character)");
  expect_refused(upload_record("?fs=3000&input=%C0%80", csv_of(r)), 400, "input: not UTF-8 text");  // an overlong NUL
  // Text in any script is a name.
  const Reply named = upload_record("?fs=3000&name=%C3%A9tude%20%E2%88%9A", csv_of(r));
  EXPECT_EQ(named.status, 201) << named.text;
  EXPECT_EQ(named.body["name"], "étude √");
}

TEST_F(RecordRoutesTest, AWavAtAnotherRateIsRefused) {
  start();
  dsp::Record rec;
  rec.fs = 48000.0;
  const FirRecord r = fir_record(500);
  rec.add("u", r.u);
  rec.add("y", r.y);
  expect_refused(upload_record("", wav_bytes(rec, dsp::WavFormat::pcm16), "audio/wav"), 400, "48000 Hz");
  // A rate given for a WAV must be the file's.
  rec.fs = kFs;
  expect_refused(upload_record("?fs=2000", wav_bytes(rec, dsp::WavFormat::pcm16), "audio/wav"), 400, "2000 Hz");
  // A CSV must say its rate.
  expect_refused(upload_record("", csv_of(r)), 400, "fs: required");
}

TEST_F(RecordRoutesTest, ANaNInACsvIsRefusedNamingItsLine) {
  start();
  std::string text = csv_of(fir_record(500));
  const std::size_t line3 = text.find('\n', text.find('\n', text.find('\n') + 1) + 1) + 1;  // the 4th line
  text.replace(line3, text.find(',', line3) - line3, "nan");
  expect_refused(upload_record("?fs=3000", text), 400, "body:4");
}

TEST_F(RecordRoutesTest, ARaggedCsvIsRefusedNamingItsLine) {
  start();
  std::string text = csv_of(fir_record(500));
  text.insert(text.find('\n', text.find('\n') + 1), ",0.5");  // line 2 has three fields
  expect_refused(upload_record("?fs=3000", text), 400, "body:2");
}

TEST_F(RecordRoutesTest, AMissingChannelIsRefusedNamingIt) {
  start();
  expect_refused(upload_record("?fs=3000&current=i", csv_of(fir_record(500))), 400, "\"i\"");
  dsp::Record rec;
  rec.fs = kFs;
  const FirRecord r = fir_record(500);
  rec.add("u", r.u);
  rec.add("y", r.y);
  expect_refused(upload_record("?output=5", wav_bytes(rec, dsp::WavFormat::float32), "audio/wav"), 400, "channel 5");
}

TEST_F(RecordRoutesTest, ATooShortRecordIsRefused) {
  start();
  expect_refused(upload_record("?fs=3000", csv_of(fir_record(kMinRecordSamples - 1))), 400,
                 "need at least " + std::to_string(kMinRecordSamples));
}

TEST_F(RecordRoutesTest, ATooLargeBodyIsRefused) {
  ServerOptions o = options(dir_ / "store");
  o.body_limit = 64 * 1024;
  start(std::move(o));
  const std::string text = csv_of(fir_record(5000));
  ASSERT_GT(text.size(), 64u * 1024u);
  expect_refused(upload_record("?fs=3000", text), 413, "64 KiB");
}

TEST_F(RecordRoutesTest, ABodyThatIsNeitherWavNorCsvIsRefused) {
  start();
  expect_refused(upload_record("?fs=3000", std::string("\x89PNG\r\n\x1a\n\0\0\0\rIHDR", 16), "image/png"), 415,
                 "neither a WAV file");
  expect_refused(upload_record("?fs=3000", "just one column\n1\n2\n", "application/octet-stream"), 415, "neither");
  // JSON (curl -d's form type, which the server reads as JSON) has commas in its first line, but is not CSV.
  expect_refused(upload_record("?fs=3000", R"({"u":[1,2],"y":[3,4]})", "application/x-www-form-urlencoded"), 415,
                 "neither");
  expect_refused(upload_record("?fs=3000", ""), 400, "body: missing");
  expect_refused(upload_record("?fs=3000&foo=1", csv_of(fir_record(500))), 400, "foo: unknown query parameter");
}

TEST_F(RecordRoutesTest, RecordsSurviveARestartAndAnUploadCutShortIsRemoved) {
  start();
  const std::string id = upload_record("?fs=3000", csv_of(fir_record(500))).body["id"];
  server_->stop();
  server_.reset();
  // A file without its entry (the process died between the two writes) and a scratch file.
  std::ofstream(dir_ / "store" / "records" / "r0123456789ab.csv") << "u,y\n1,2\n";
  std::ofstream(dir_ / "store" / "records" / ".upload.tmp-abcdef.csv") << "u,y\n";
  start();
  EXPECT_EQ(get("/api/records/" + id).status, 200);
  EXPECT_EQ(get("/api/records").body["total"], 1);
  EXPECT_EQ(stored_files(), 2u);
}

TEST_F(RecordRoutesTest, AnIdentificationTakesAnUploadedRecordSplitByValFraction) {
  start();
  const std::string id = upload_record("?fs=3000", csv_of(fir_record(2000))).body["id"];
  const Reply job = post("/api/jobs", json{{"kind", "identify-linear"},
                                           {"params", {{"record", id}, {"val_fraction", 0.25}, {"method", "fir"},
                                                       {"order", 3}, {"delay", 0}}}});
  ASSERT_EQ(job.status, 202) << job.text;
  const json done = wait_job(job.body["id"]);
  ASSERT_EQ(done["state"], "succeeded") << done.dump();
  // The FIR model of order 3 is exact: J is at rounding level (of the scaled least squares, ~1e-6 %). The
  // validation part is the last quarter, 500 samples, of which the fit shows all but the simulation's initial
  // state (init_samples: 50).
  EXPECT_LT(done["result"]["j_val_pct"].get<double>(), 1e-4);
  EXPECT_EQ(done["result"]["plots"]["fit"]["t"].size(), static_cast<std::size_t>(500 - init_samples(500)));
  EXPECT_EQ(done["params"]["val_fraction"], 0.25);
}

TEST_F(RecordRoutesTest, JobParamsNamingAnUploadedRecordAreChecked) {
  start();
  const std::string id = upload_record("?fs=3000", csv_of(fir_record(500))).body["id"];
  const auto refused = [&](const json& params, const std::string& fragment) {
    const Reply r = post("/api/jobs", json{{"kind", "identify-linear"}, {"params", params}});
    EXPECT_EQ(r.status, 400) << r.text;
    EXPECT_NE(error_message(r).find(fragment), std::string::npos) << error_message(r);
  };
  refused({{"record", "r000000000000"}}, "no uploaded record \"r000000000000\"");
  // 500 samples, a third validating: 333 + 167, and 167 is too few.
  refused({{"record", id}}, "params.val_fraction");
  refused({{"record", id}, {"val_fraction", 0.95}}, "params.val_fraction");
  refused({{"excite", json::object()}, {"val_fraction", 0.2}}, "params.val_fraction: splits an uploaded record");
  // No validation part at all is a split too (no order scan then).
  const Reply ok = post("/api/jobs", json{{"kind", "identify-linear"}, {"params", {{"record", id}, {"val_fraction", 0.0}}}});
  EXPECT_EQ(ok.status, 202) << ok.text;
  refused({{"record", id}, {"val_fraction", 0.0}, {"scan", {2, 4}}}, "params.scan: an order scan needs validation data");
}

}  // namespace
}  // namespace panelbass::api
