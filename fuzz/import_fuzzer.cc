// libFuzzer target for the import readers (import/): the input's first byte picks the reader —
// RTKLIB .pos, KF-GINS GNSS, KF-GINS IMU, a mapped IMU CSV, a PX4 ULog (byte 5)
// (t,ax,ay,az,gx,gy,gz,- in ms, g, deg/s with a mounting rotation) — the rest is the file. Byte 4
// assembles a dataset from a KF-GINS IMU text and a fixed valid GNSS solution. Readers must accept
// the text or throw std::runtime_error / std::invalid_argument with a message; anything else is a
// finding. Byte 6: the mapped CSV with a dual-antenna heading (t,ax,ay,az,gx,gy,gz,hdg,hdg_sd)
// assembled with the fixed GNSS; byte 7: with a magnetometer (mx,my,mz) and a declination. The
// ULog reader also extracts the GNSS heading and the magnetometer (--heading gps, mag).
// Byte 8: an ArduPilot DataFlash log (.bin), read and imported with IMU and with IMU3 cut.
// INSID_FUZZ_READER=N (0-8) pins the reader, whatever the first byte says (one reader per
// run, e.g. scripts/fuzz.sh's per-reader runs of the ULog and CSV readers).
#include <cstdint>
#include <cstdio>
#include <cstdlib>
#include <stdexcept>
#include <string>

#include "import/ardupilot_import.h"
#include "import/csv_imu.h"
#include "import/dataflash.h"
#include "import/gnss_solution.h"
#include "import/importer.h"
#include "import/kf_gins.h"
#include "import/ulog.h"
#include "import/ulog_import.h"

namespace {

const insid::importers::GnssSolution& fixed_gnss() {
  static const insid::importers::GnssSolution g = [] {
    std::string text;
    for (int k = 0; k < 40; ++k)
      text += std::to_string(100 + k * 0.25) +
              " 40.1 -105.1 1600 0.01 0.01 0.02 0 0 0 0.05 0.05 0.05\n";
    return insid::importers::parse_kf_gins_gnss(text, "gnss.txt", 2381);
  }();
  return g;
}

}  // namespace

static int pinned_reader() {
  static const int reader = [] {
    const char* text = std::getenv("INSID_FUZZ_READER");
    return text == nullptr ? -1 : std::atoi(text) % 9;
  }();
  return reader;
}

extern "C" int LLVMFuzzerTestOneInput(const std::uint8_t* data, std::size_t size) {
  if (size == 0) return 0;
  const std::string text(reinterpret_cast<const char*>(data + 1), size - 1);
  namespace im = insid::importers;
  try {
    switch (pinned_reader() >= 0 ? pinned_reader() : data[0] % 9) {
      case 0:
        im::parse_rtklib_pos(text, "fuzz.pos");
        break;
      case 1:
        im::parse_kf_gins_gnss(text, "gnss.txt", 2381);
        break;
      case 2:
        im::parse_kf_gins_imu(text, "imu.txt", 2381);
        break;
      case 3: {
        im::CsvImuSpec spec;
        spec.columns = im::CsvImuSpec::parse_columns("t,ax,ay,az,gx,gy,gz,-");
        spec.parse_units("ms,g,deg/s");
        spec.mounting_rpy_deg = {180.0, 0.0, -90.0};
        im::read_csv_imu(text, "imu.csv", spec, 2381);
        break;
      }
      case 5: {
        const im::UlogFile log = im::UlogFile::parse(text, "fuzz.ulg");
        for (const char* topic :
             {"vehicle_imu", "sensor_combined", "vehicle_gps_position", "sensor_gps"})
          for (const auto& [instance, n] : log.instances(topic)) (void)n, (void)instance;
        im::extract_ulog(log, "fuzz.ulg", im::UlogImportOptions{});
        for (const char* heading : {"gps", "mag"}) {
          im::UlogImportOptions options;
          options.heading = heading;
          try {
            im::extract_ulog(log, "fuzz.ulg", options);
          } catch (const std::runtime_error&) {
          }
        }
        break;
      }
      case 6:
      case 7: {
        const bool mag = (pinned_reader() >= 0 ? pinned_reader() : data[0] % 9) == 7;
        im::CsvImuSpec spec;
        spec.columns = im::CsvImuSpec::parse_columns(mag ? "t,ax,ay,az,gx,gy,gz,mx,my,mz"
                                                         : "t,ax,ay,az,gx,gy,gz,hdg,hdg_sd");
        spec.parse_units("s,g,deg/s");
        spec.time_scale = "gps-sow";
        im::AssembleOptions options;
        options.align_s = 1.0;
        if (mag) options.declination_deg = 7.5;
        im::assemble_dataset(im::read_csv_imu(text, "imu.csv", spec, 2381), fixed_gnss(), options);
        break;
      }
      case 8: {
        const im::DataFlashFile log = im::DataFlashFile::parse(text, "fuzz.bin");
        (void)log.messages_summary();
        im::ArduPilotImportOptions cut;
        cut.imu = "IMU3";
        cut.t_start_s = 1.0;
        cut.t_end_s = 100.0;
        try {
          im::extract_ardupilot(log, "fuzz.bin", cut);
        } catch (const std::runtime_error&) {
        }
        im::extract_ardupilot(log, "fuzz.bin", im::ArduPilotImportOptions{});
        break;
      }
      default: {
        im::AssembleOptions options;
        options.align_s = 1.0;
        im::assemble_dataset(im::parse_kf_gins_imu(text, "imu.txt", 2381), fixed_gnss(), options);
        break;
      }
    }
  } catch (const std::invalid_argument&) {
  } catch (const std::runtime_error&) {  // includes DatasetError
  } catch (const std::exception& e) {
    std::fprintf(stderr, "finding: neither invalid_argument nor runtime_error: %s\n", e.what());
    std::abort();
  }
  return 0;
}
