// import_recording(spec): the spec refused up front naming the bad value, and one call from the
// source files to the dataset directory with its provenance, as `insid import` writes it.
#include <filesystem>
#include <stdexcept>
#include <string>
#include <vector>

#include <gtest/gtest.h>

#include "data/dataset.h"
#include "import/import_recording.h"
#include "import/kf_gins.h"
#include "scenarios/scenario.h"
#include "test_support/files.h"

namespace insid::importers {
namespace {
namespace fs = std::filesystem;

ImportSpec spec_of(ImportSource source) {
  ImportSpec spec;
  spec.source = std::move(source);
  spec.out_dir = "never-written";
  return spec;
}

TEST(ImportRecording, TheSpecIsRefusedUpFrontNamingTheBadValue) {
  EXPECT_EQ(spec_of(CsvImportSource{}).validate(),
            "--columns: role 't' must appear exactly once, got 0 (roles: t, ax, ay, az, gx, gy, "
            "gz, -)");
  CsvImportSource csv;
  csv.imu.columns = {"t", "ax", "ay", "az", "gx", "gy", "gz"};
  EXPECT_EQ(spec_of(csv).validate(), "");
  csv.gnss_quality.clear();
  EXPECT_EQ(spec_of(csv).validate(), "--gnss-quality: give at least one RTKLIB quality flag (1-6)");

  UlogImportSource ulog;
  ulog.every_imu_instance = true;
  ulog.options.imu_topic = "sensor_combined";
  EXPECT_EQ(spec_of(ulog).validate(),
            "--imu-instance all imports every instance of vehicle_imu (one per physical IMU); "
            "--imu-topic 'sensor_combined' has one");
  ulog.options.imu_topic = "";
  EXPECT_EQ(spec_of(ulog).validate(), "");

  ArduPilotImportSource ardupilot;
  ardupilot.options.imu = "IMU4";
  EXPECT_EQ(spec_of(ardupilot).validate(),
            "--imu 'IMU4': must be IMU, IMU2 or IMU3 (the log's IMU messages), or all (every one "
            "the log has, into --out/IMU, --out/IMU2, --out/IMU3)");
  ardupilot.every_imu = true;  // options.imu is not read
  EXPECT_EQ(spec_of(ardupilot).validate(), "");

  KfGinsImportSource kf;
  kf.gps_week = -1;
  EXPECT_EQ(spec_of(kf).validate(), "--gps-week -1: must be in 0-100000");

  ImportSpec spec = spec_of(KfGinsImportSource{});
  spec.max_input_mb = 0.5;
  EXPECT_EQ(spec.validate(), "--max-input-mb 0.5: must be in [1, 1048576] MiB");
  spec.max_input_mb = 4096;
  spec.assembly.static_rate_dps = 0.0;
  EXPECT_EQ(spec.validate(), "--static-rate 0: must be in (0, 1000] deg/s");
  // The library call refuses it too, before any work: nothing is written.
  EXPECT_THROW(import_recording(spec), std::invalid_argument);
  EXPECT_FALSE(fs::exists(spec.out_dir));
}

// GIVEN the straight flight as KF-GINS text files WHEN imported by one call THEN the dataset is
// written with provenance.json, the report holds what was written, and the progress is told.
TEST(ImportRecording, KfGinsFilesBecomeADatasetDirectoryWithProvenance) {
  scenarios::ScenarioConfig cfg = scenarios::preset_scenario("straight");
  cfg.flight_s = 120.0;
  cfg.align_s = 60.0;
  Dataset original = scenarios::simulate(cfg);
  original.meta.earth = EarthModel::wgs84();
  const test::TempDir tmp;
  ASSERT_FALSE(tmp.path.empty());
  KfGinsImportSource kf;
  kf.imu_path = (tmp.path / "imu.txt").string();
  kf.gnss_path = (tmp.path / "gnss.txt").string();
  kf.gps_week = 2381;
  test::write_file(kf.imu_path, kf_gins_imu_text(original, 1000.0));
  test::write_file(kf.gnss_path, kf_gins_gnss_text(original, 1000.0, 0.02, 0.03));
  ImportSpec spec = spec_of(kf);
  spec.out_dir = (tmp.path / "data").string();
  spec.assembly.align_s = original.meta.align_s;
  std::vector<std::string> notes, data_notes;
  ImportProgress progress;
  progress.note = [&notes](const std::string& text) { notes.push_back(text); };
  progress.data_note = [&data_notes](const std::string& text) { data_notes.push_back(text); };

  const ImportReport report = import_recording(spec, progress);

  ASSERT_EQ(report.datasets.size(), 1u);
  const ImportedDataset& written = report.datasets.front();
  EXPECT_EQ(written.dir, spec.out_dir);
  const Dataset back = load_dataset(spec.out_dir);
  EXPECT_EQ(back.imu.size(), original.imu.size());
  EXPECT_EQ(written.dataset->imu.size(), back.imu.size());
  EXPECT_EQ(written.dataset->gnss.size(), back.gnss.size());
  EXPECT_EQ(test::read_file(fs::path(spec.out_dir) / "provenance.json"),
            written.provenance.dump(2) + "\n");
  EXPECT_EQ(written.provenance["command"], "insid import kf-gins");
  EXPECT_EQ(written.provenance["options"]["gps_week"], 2381);
  EXPECT_EQ(written.provenance["options"]["align_s"], original.meta.align_s);
  EXPECT_EQ(written.provenance["sources"][0]["role"], "imu");
  EXPECT_EQ(written.provenance["sources"][1]["role"], "gnss");
  ASSERT_EQ(notes.size(), 1u);
  EXPECT_EQ(notes[0].rfind("wrote " + spec.out_dir + " (insid-dataset/2): " +
                               std::to_string(back.imu.size()) + " IMU rows",
                           0),
            0u)
      << notes[0];
}

}  // namespace
}  // namespace insid::importers
