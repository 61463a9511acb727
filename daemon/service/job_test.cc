// A job's record as stored (job.json) and reported: the options' enums are
// text there, exactly as before they were enums, so stored jobs still load.
#include "daemon/service/job.h"

#include <gtest/gtest.h>

#include <stdexcept>
#include <string>

namespace dfsm::service {
namespace {

// A record as dfsmd has always written it.
nlohmann::json StoredRecord(const std::string& when, const std::string& init) {
  return nlohmann::json::parse(R"({"id":"j1700000000000-00ab","origin":"capture",
      "status":"queued","stage":"","created_ms":1700000000000,
      "options":{"frames":10,"when":")" +
                               when + R"(","planes":128,"grid":0,"init":")" + init +
                               R"(","rolling_shutter":"global","dense":true,
      "keep_burst":true,"calibration":"auto","camera":"capture"}})");
}

std::string RecordErrorOf(const nlohmann::json& record) {
  try {
    JobFromJson(record);
  } catch (const std::invalid_argument& e) {
    return e.what();
  }
  return "";
}

TEST(JobTest, TheOptionsAreWrittenAsTheirNames) {
  Job job;
  job.id = "j1700000000000-00ab";
  EXPECT_EQ(ToJson(job).at("options").at("when"), "last");
  EXPECT_EQ(ToJson(job).at("options").at("init"), "rank1");
  job.options.when = BurstWhen::kNext;
  job.options.init = InitMode::kNaive;
  EXPECT_EQ(ToJson(job).at("options").at("when"), "next");
  EXPECT_EQ(ToJson(job).at("options").at("init"), "naive");
  job.options.when.reset();  // an upload's
  EXPECT_EQ(ToJson(job).at("options").at("when"), "");
}

TEST(JobTest, StoredRecordsLoadAndRoundTrip) {
  for (const char* when : {"last", "next", ""}) {
    for (const char* init : {"rank1", "naive"}) {
      SCOPED_TRACE(std::string(when) + " " + init);
      const nlohmann::json stored = StoredRecord(when, init);
      const Job job = JobFromJson(stored);
      EXPECT_EQ(job.options.when.has_value(), *when != '\0');
      EXPECT_EQ(job.options.init,
                std::string(init) == "naive" ? InitMode::kNaive : InitMode::kRankOne);
      const nlohmann::json written = ToJson(job);
      EXPECT_EQ(written.at("options"), stored.at("options"));
    }
  }
  EXPECT_EQ(JobFromJson(StoredRecord("next", "rank1")).options.when, BurstWhen::kNext);
  // Records from before "camera" existed: a capture's was the capture camera,
  // an upload's is not known and counts as another camera's.
  nlohmann::json unnamed = StoredRecord("last", "rank1");
  unnamed["options"].erase("camera");
  EXPECT_EQ(JobFromJson(unnamed).options.camera, "capture");
  unnamed["origin"] = "upload";
  EXPECT_EQ(JobFromJson(unnamed).options.camera, "other");
  // Records from before "when" existed were captures of the last frames.
  nlohmann::json old = StoredRecord("last", "rank1");
  old["options"].erase("when");
  EXPECT_EQ(JobFromJson(old).options.when, BurstWhen::kLast);
}

// "frames": "auto" is stored as the request gave it, with its max_frames.
TEST(JobTest, AutoFramesRoundTripWithTheirMaximum) {
  Job job;
  job.id = "j1700000000000-00ab";
  job.options.auto_frames = true;
  job.options.frames = 24;
  const nlohmann::json json = ToJson(job);
  EXPECT_EQ(json.at("options").at("frames"), "auto");
  EXPECT_EQ(json.at("options").at("max_frames"), 24);
  const Job loaded = JobFromJson(json);
  EXPECT_TRUE(loaded.options.auto_frames);
  EXPECT_EQ(loaded.options.frames, 24);
  job.options.auto_frames = false;
  EXPECT_FALSE(ToJson(job).at("options").contains("max_frames"));
  EXPECT_FALSE(JobFromJson(ToJson(job)).options.auto_frames);
}

TEST(JobTest, AnUnknownStoredOptionIsNamedWithItsValue) {
  const std::string when = RecordErrorOf(StoredRecord("soon", "rank1"));
  EXPECT_NE(when.find("options.when"), std::string::npos) << when;
  EXPECT_NE(when.find("\"soon\""), std::string::npos) << when;
  const std::string init = RecordErrorOf(StoredRecord("last", "rank2"));
  EXPECT_NE(init.find("options.init"), std::string::npos) << init;
  EXPECT_NE(init.find("\"rank2\""), std::string::npos) << init;

  nlohmann::json number = StoredRecord("last", "rank1");
  number["options"]["init"] = 1;
  EXPECT_EQ(RecordErrorOf(number), "options.init must be a string, got 1");
  nlohmann::json missing = StoredRecord("last", "rank1");
  missing["options"].erase("init");
  EXPECT_EQ(RecordErrorOf(missing), "options.init is missing");
}

}  // namespace
}  // namespace dfsm::service
