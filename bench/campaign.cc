#include "bench/campaign.h"

#include <omp.h>
#include <signal.h>
#include <unistd.h>

#include <algorithm>
#include <cerrno>
#include <chrono>
#include <cmath>
#include <ctime>
#include <exception>
#include <filesystem>
#include <fstream>
#include <iostream>
#include <limits>
#include <map>
#include <set>
#include <sstream>
#include <stdexcept>
#include <thread>

#include "base/json_object.h"
#include "base/json_reader.h"
#include "base/output_dir.h"
#include "base/threads.h"
#include "bench/cluster.h"
#include "data/dataset.h"
#include "identification/identify.h"

namespace insid::campaign {
namespace fs = std::filesystem;

namespace {

void report_progress(const RunOptions& options, const ProgressEvent& event) {
  if (!options.quiet && options.progress) options.progress(event);
}

std::string host_name() {
  char buffer[256] = {0};
  if (gethostname(buffer, sizeof(buffer) - 1) != 0) return "unknown";
  return buffer;
}

// Why a run record cannot be used ("" when it can), in the typed reader's wording
// ("<source>: <path>: <what>", base/json_object.h): it names this run under a schema insid reads
// and every number the summary and the sweep read is a finite number.
std::string run_record_problem(const nlohmann::json& j, const std::string& source,
                               const std::string& scenario, const std::string& label,
                               std::uint64_t seed) {
  try {
    const JsonObject record = JsonObject::any_keys(j, source, "");
    record.field("schema").choice({kRunSchema, kRunSchemaPrevious, kRunSchemaOld});
    for (const auto& [key, want] :
         {std::pair<const char*, std::string>{"scenario", scenario}, {"algorithm", label}}) {
      const JsonField field = record.field(key);
      if (field.string() != want)
        field.fail("expected \"" + want + "\" (this run's), found " +
                   describe_json_value(field.value()));
    }
    const JsonField seed_field = record.field("seed");
    if (!seed_field.value().is_number_unsigned() || seed_field.value().get<std::uint64_t>() != seed)
      seed_field.fail("expected " + std::to_string(seed) + " (this run's), found " +
                      describe_json_value(seed_field.value()));
    const JsonObject result = record.field("result").map();
    for (const char* key : {"fitness", "wall_s", "evaluations"}) result.number(key);
    record.number("optimum_fitness");
    const auto non_empty = [](const JsonObject& object, const char* key) {
      const JsonArray array = object.array(key);
      if (array.empty()) object.fail(key, "expected a non-empty array, found []");
      return array;
    };
    const JsonArray history = non_empty(result, "history");
    for (std::size_t i = 0; i < history.size(); ++i) history[i].map().number("best_fitness");
    non_empty(result, "best_per_evaluation").numbers();
    for (const char* block : {"error_sigma", "error_vs_optimum_sigma"}) {
      if (!record.has(block) && std::string_view(block) == "error_sigma") continue;
      const JsonObject errors = record.field(block).map();
      for (const auto& item : errors.value().items()) errors.number(item.key());
    }
  } catch (const JsonFieldError& e) {
    return e.what();
  }
  return "";
}

}  // namespace

nlohmann::json read_run_record(const fs::path& path, const std::string& scenario,
                               const std::string& label, std::uint64_t seed) {
  nlohmann::json j = read_json_file(path);
  if (std::string problem = run_record_problem(j, path.string(), scenario, label, seed);
      !problem.empty())
    throw std::runtime_error(problem);
  return j;
}

std::string run_file_problem(const fs::path& path, const std::string& scenario,
                             const std::string& label, std::uint64_t seed) {
  std::error_code ec;
  if (!fs::exists(path, ec)) return "missing";
  try {
    read_run_record(path, scenario, label, seed);
    return "";
  } catch (const std::exception& e) {
    return e.what();  // truncated, not JSON, a key given twice, unreadable, not this run's
  }
}

namespace {

// The deterministic run list: scenarios, then algorithms, then seeds, in config order. Shards
// and MPI units are positions in this list, so every split does the same runs.
std::vector<RunSpec> run_list(const CampaignConfig& config, const std::string& out_dir) {
  std::vector<RunSpec> runs;
  for (std::size_t s = 0; s < config.scenarios.size(); ++s)
    for (std::size_t a = 0; a < config.algorithms.size(); ++a)
      for (std::uint64_t seed : config.seeds)
        runs.push_back(
            {s, a, seed,
             run_file(out_dir, config.scenarios[s].name, config.algorithms[a].label, seed)});
  return runs;
}

std::string run_problem(const CampaignConfig& config, const RunSpec& run) {
  return run_file_problem(run.path, config.scenarios[run.scenario].name,
                          config.algorithms[run.algorithm].label, run.seed);
}

// What insid writes at the top of a campaign directory (bench, sweep, the report script).
const OutputKind kCampaignKind{"an insid campaign directory",
                               {"manifest.json", "runs", "optimum", "summary.json", "sweep.json",
                                "sweep.csv", "report.md", "figures", FileLock::kRunLockName},
                               {"runs", "optimum", "figures"}};

// Check out_dir's manifest against `config` (a different campaign is refused unless
// force_new) and write the manifest, under the directory's locks (base/output_dir.h): the
// directory itself gates the check-and-write; `.insid-lock` is held alone, for as long as the
// campaign runs, by a process that does all the runs (a plain run, an MPI launch's rank 0) or
// starts a new campaign there, and shared by shards (--shard i/N) of one campaign, so a second
// plain run, or a shard beside a plain run, fails naming the holder (pid, host, since when:
// the lock file's text, see write_holders) instead of doing every run again. flock(2) locks
// die with their process, so a killed holder leaves no lock behind. Temporary files left by killed
// processes are removed when no other process runs. Returns the run lock, to hold until the
// campaign ends, and the number of shards the directory is split into (0 when unknown): this
// launch's, or the one recorded by earlier shards of the same campaign.
// Who holds a campaign directory's run lock, one line per process in the lock file:
// "pid <pid> on <host> since <UTC time>, <what>". Written under the gate lock: a process that
// holds the lock alone replaces the text, a shard adds its line to those of the shards still
// running (a line of a process on this host that has stopped is dropped).
struct Holder {
  long pid = 0;
  std::string host, line;
};

std::vector<Holder> read_holders(const FileLock& lock) {
  std::vector<Holder> holders;
  std::istringstream in(lock.read_text());
  for (std::string line; std::getline(in, line);) {
    std::istringstream words(line);
    std::string pid_word, on_word;
    Holder h;
    if (words >> pid_word >> h.pid >> on_word >> h.host && pid_word == "pid" && on_word == "on") {
      h.line = line;
      holders.push_back(std::move(h));
    }
  }
  return holders;
}

// False only for a process of this host that is gone (a line left by a killed holder).
bool may_be_running(const Holder& h) {
  if (h.host != host_name()) return true;
  return ::kill(static_cast<pid_t>(h.pid), 0) == 0 || errno == EPERM;
}

std::string live_holders(const FileLock& lock) {
  std::string text;
  for (const Holder& h : read_holders(lock))
    if (may_be_running(h)) text += (text.empty() ? "" : "; ") + h.line;
  return text.empty() ? "holder not recorded" : text;
}

std::string utc_now() {
  const std::time_t now = std::time(nullptr);
  std::tm utc{};
  gmtime_r(&now, &utc);
  char buffer[32];
  std::strftime(buffer, sizeof(buffer), "%Y-%m-%dT%H:%M:%SZ", &utc);
  return buffer;
}

void write_holders(FileLock& lock, bool alone, const Shard& shard) {
  std::string text;
  if (!alone)
    for (const Holder& h : read_holders(lock))
      if (may_be_running(h) && h.pid != static_cast<long>(getpid())) text += h.line + "\n";
  text += "pid " + std::to_string(getpid()) + " on " + host_name() + " since " + utc_now() + ", " +
          (shard.active() ? "shard " + shard.to_string() : std::string("all runs")) + "\n";
  // In place, not by rename: the lock lives on this file's inode (written through its
  // descriptor, never through a path that could have become a link).
  lock.write_text(text);
}

// A shard joining running shards: refused when a live holder runs the same shard, or a shard
// of another split (its line ends in "shard j/M", see write_holders).
void check_shard_joins(const FileLock& lock, const RunOptions& options) {
  const std::string mine = "shard " + options.shard.to_string();
  const std::string split = "/" + std::to_string(options.shard.count);
  for (const Holder& h : read_holders(lock)) {
    if (!may_be_running(h)) continue;
    const std::size_t comma = h.line.rfind(", shard ");
    if (comma == std::string::npos) continue;
    const std::string theirs = h.line.substr(comma + 2);
    if (theirs == mine)
      throw std::runtime_error(options.out_dir + ": " + mine + " is already running there (" +
                               h.line +
                               "); each shard runs once at a time: wait for it, or run another "
                               "shard");
    if (theirs.size() < split.size() ||
        theirs.compare(theirs.size() - split.size(), split.size(), split) != 0)
      throw std::runtime_error(options.out_dir + ": " + mine +
                               " cannot join a campaign split another way (" + h.line +
                               "); every shard of one campaign must give the same N");
  }
}

struct DirectoryClaim {
  std::unique_ptr<FileLock> run_lock;
  int shard_count = 0;
};

// The contents of the scenarios read from data directories (scenario name -> dataset_digest):
// a campaign over data that changed since its runs is a different campaign.
nlohmann::json data_digests(const CampaignConfig& config) {
  nlohmann::json digests = nlohmann::json::object();
  for (const ScenarioSpec& s : config.scenarios)
    if (!s.data_dir.empty()) digests[s.name] = dataset_digest(s.data_dir);
  return digests;
}

// How campaign files are written. Once prepare_directory has accepted the directory (empty,
// holding only files insid wrote, or a campaign with insid's manifest; anything else only with
// --force) its manifest, summary, run and optimum paths are insid's own: they are replaced
// whoever wrote the bytes there (a run file of an older insid, a damaged one being redone), but
// never through a link (write_file_atomic_under).
WriteOptions own_campaign_path() {
  WriteOptions w;
  w.replace_foreign = true;
  return w;
}

// A campaign's own layout under runs/ and optimum/ (bench/campaign_config.cc run_file,
// optimum_file): <scenario>/<label>/seed_<n>.json and <scenario>.json, plain names only.
bool is_run_layout(const fs::path& rel) {
  std::vector<std::string> parts;
  for (const fs::path& p : rel) parts.push_back(p.string());
  const std::string& file = parts.empty() ? std::string() : parts.back();
  auto plain = [](const std::string& name) {
    try {
      checked_path_component(name, "name");
      return true;
    } catch (const std::invalid_argument&) {
      return false;
    }
  };
  if (parts.size() != 3 || !plain(parts[0]) || !plain(parts[1])) return false;
  if (file.size() < 11 || file.compare(0, 5, "seed_") != 0 ||
      file.compare(file.size() - 5, 5, ".json") != 0)
    return false;
  for (std::size_t i = 5; i + 5 < file.size(); ++i)
    if (file[i] < '0' || file[i] > '9') return false;
  return true;
}

bool is_optimum_layout(const fs::path& rel) {
  const std::string name = rel.string();
  return std::distance(rel.begin(), rel.end()) == 1 && name.size() > 5 &&
         name.compare(name.size() - 5, 5, ".json") == 0;
}

// --force-new: the results of the campaign found in `dir` (a directory with insid's manifest)
// are discarded: the files insid wrote or that sit at the campaign's own paths (run files,
// optimum files, summary.json; never through a link). Anything else under runs/ or optimum/
// (a user's notes, a link) stops the new campaign, named, and is kept.
void discard_campaign_results(const fs::path& dir) {
  std::vector<std::string> kept;
  for (const fs::path& p : remove_own_files(dir / "runs", is_run_layout))
    kept.push_back((fs::path("runs") / p).lexically_normal().string());
  for (const fs::path& p : remove_own_files(dir / "optimum", is_optimum_layout))
    kept.push_back((fs::path("optimum") / p).lexically_normal().string());
  std::error_code ec;
  const fs::file_status summary = fs::symlink_status(dir / "summary.json", ec);
  if (fs::is_regular_file(summary))
    fs::remove(dir / "summary.json");  // the campaign's own path in its own directory
  else if (fs::exists(summary))
    kept.push_back("summary.json");
  if (kept.empty()) return;
  std::string list;
  for (std::size_t i = 0; i < kept.size() && i < 5; ++i) list += (i ? ", " : "") + kept[i];
  if (kept.size() > 5) list += " and " + std::to_string(kept.size() - 5) + " more";
  throw std::runtime_error(
      dir.string() + ": --force-new removed the results insid wrote there but kept " +
      std::to_string(kept.size()) + " entries it did not write (or that changed since): " + list +
      ". Move them away yourself, or choose another --out.");
}

// Refuses, before any work, a campaign whose outputs would replace a file it reads: its config
// (options.inputs) or a scenario's dataset files. No --force lifts this.
void refuse_replacing_campaign_inputs(const CampaignConfig& config, const RunOptions& options) {
  std::vector<fs::path> inputs = options.inputs;
  for (const ScenarioSpec& s : config.scenarios)
    if (!s.data_dir.empty())
      for (const std::string& name : dataset_directory_entries())
        inputs.push_back(fs::path(s.data_dir) / name);
  const fs::path dir(options.out_dir);
  for (const std::string& name : kCampaignKind.own_entries) {
    const auto& dirs = kCampaignKind.own_directories;
    const bool whole = std::find(dirs.begin(), dirs.end(), name) != dirs.end();
    refuse_replacing_inputs(dir / name, inputs, whole);
  }
}

DirectoryClaim prepare_directory(const CampaignConfig& config, const RunOptions& options,
                                 int threads) {
  refuse_replacing_campaign_inputs(config, options);
  const nlohmann::json config_json = config.to_json();
  const nlohmann::json digests = data_digests(config);
  const fs::path dir(options.out_dir);
  const fs::path manifest_path = dir / "manifest.json";
  std::error_code ec;
  if (!fs::exists(manifest_path, ec) && !options.into_foreign_directory)
    require_own_or_empty(dir, kCampaignKind,
                         "give --force to add the campaign's files and keep the rest");
  fs::create_directories(dir);
  FileLock gate(dir, FileLock::Target::kDirectory);
  gate.lock(FileLock::Mode::kExclusive);
  DirectoryClaim claim;
  const fs::path lock_path = dir / FileLock::kRunLockName;
  claim.run_lock = std::make_unique<FileLock>(lock_path);
  const bool alone = claim.run_lock->try_lock(FileLock::Mode::kExclusive);
  // A plain run or an MPI launch does every run: beside any other process it would do them twice.
  const bool whole_campaign = !options.shard.active();
  const std::string in_use =
      options.out_dir + " is in use by another insid process running a campaign there now (" +
      live_holders(*claim.run_lock) + "); wait for it to finish, or choose another --out" +
      (whole_campaign ? " (only shards of one campaign, --shard i/N, share a directory)" : "");
  if (whole_campaign && !alone) throw std::runtime_error(in_use);
  // A shard joins other shards (shared), never a process that holds the directory alone.
  if (!whole_campaign && !alone && !claim.run_lock->try_lock(FileLock::Mode::kShared))
    throw std::runtime_error(in_use);
  // ... and only shards of the same split, each index once: the same i/N twice, or i/N beside
  // j/M with M != N, would do runs twice.
  if (!whole_campaign && !alone) check_shard_joins(*claim.run_lock, options);
  if (alone) {
    const int removed = remove_stale_temporaries(dir);
    if (removed > 0)
      report_progress(options, {.kind = ProgressEvent::Kind::kRemovedTemporaries,
                                .path = options.out_dir,
                                .count = removed});
  }
  int shard_count = options.shard.count;
  if (fs::exists(manifest_path)) {
    nlohmann::json old;
    try {
      old = read_json_file(manifest_path);
    } catch (const std::exception& e) {
      throw std::runtime_error(manifest_path.string() + ": unreadable manifest (" + e.what() +
                               "); use --force-new to start over");
    }
    std::string diff = config_difference(old.value("config", nlohmann::json()), config_json);
    if (diff.empty() && old.contains("data_sha256") && old["data_sha256"] != digests)
      diff = "data_sha256 (a scenario's data files changed since its runs)";
    if (!diff.empty()) {
      if (!options.force_new)
        throw std::runtime_error(options.out_dir + " holds results of a different campaign ('" +
                                 old.value("config", nlohmann::json::object()).value("name", "?") +
                                 "'; first difference at " + diff +
                                 "). Use --force-new to discard them, or choose another --out.");
      if (!alone) throw std::runtime_error(in_use);
      discard_campaign_results(dir);
    } else if (shard_count == 0) {
      shard_count = old.value("shards", 0);
    }
  } else if (!alone) {
    throw std::runtime_error(in_use);
  }
  nlohmann::json manifest;
  manifest["schema"] = kManifestSchema;
  manifest["build"] = build_info_json();
  manifest["host"] = host_name();
  manifest["cores"] = std::thread::hardware_concurrency();
  manifest["threads"] = threads;
  if (shard_count > 0) manifest["shards"] = shard_count;
  if (options.cluster != nullptr) manifest["mpi_ranks"] = options.cluster->size();
  manifest["config"] = config_json;
  if (!digests.empty()) manifest["data_sha256"] = digests;
  for (const auto& item : options.manifest_extra.items()) manifest[item.key()] = item.value();
  write_file_atomic(manifest_path, manifest.dump(2) + "\n", own_campaign_path());
  // A shard shares the lock with the other shards (a conversion; safe: we hold the gate).
  if (!whole_campaign) claim.run_lock->lock(FileLock::Mode::kShared);
  write_holders(*claim.run_lock, alone, options.shard);
  claim.shard_count = shard_count;
  return claim;
}

// MPI work units: consecutive runs of one scenario (so that they share a lock-step wave), about
// four per thread to keep the batched kernel's groups full, but small enough that every rank
// gets about four units, so that a rank finishing early can take over work. A unit's first
// number is 1 when the rank that gets it should find its scenario's missing optimum: units are
// dealt in order, so the first unit of a scenario reaches its rank before any other unit of it
// and no rank waits for an optimum that nobody finds. The other numbers are run positions.
std::vector<WorkUnit> make_units(const CampaignConfig& config, const std::vector<RunSpec>& runs,
                                 const std::vector<std::size_t>& pending, int threads, int ranks,
                                 const std::string& out_dir) {
  const std::size_t per_rank = (pending.size() + 4 * static_cast<std::size_t>(ranks) - 1) /
                               (4 * static_cast<std::size_t>(ranks));
  const std::size_t unit_runs =
      std::clamp<std::size_t>(per_rank, 1, 4 * static_cast<std::size_t>(threads));
  std::vector<WorkUnit> units;
  std::set<std::size_t> scenarios_seen;
  for (std::size_t i = 0; i < pending.size();) {
    const std::size_t scenario = runs[pending[i]].scenario;
    const bool first = scenarios_seen.insert(scenario).second;
    const fs::path optimum = optimum_file(out_dir, config.scenarios[scenario].name);
    WorkUnit unit{first && !fs::exists(optimum) ? 1 : 0};
    while (i < pending.size() && runs[pending[i]].scenario == scenario && unit.size() <= unit_runs)
      unit.push_back(static_cast<std::int64_t>(pending[i++]));
    units.push_back(std::move(unit));
  }
  return units;
}

}  // namespace

std::string missing_runs_report(const std::string& out_dir, const CampaignConfig& config,
                                int shard_count) {
  const std::vector<RunSpec> runs = run_list(config, out_dir);
  std::map<int, std::vector<std::string>> missing_by_shard;  // shard 0 when unknown
  std::size_t missing = 0;
  for (std::size_t i = 0; i < runs.size(); ++i) {
    const std::string problem = run_problem(config, runs[i]);
    if (problem.empty()) continue;
    ++missing;
    const int shard =
        shard_count > 0 ? static_cast<int>(i % static_cast<std::size_t>(shard_count)) + 1 : 0;
    missing_by_shard[shard].push_back(fs::relative(runs[i].path, out_dir).string() +
                                      (problem == "missing" ? "" : " (damaged: " + problem + ")"));
  }
  if (missing == 0) return "";
  std::ostringstream report;
  report << missing << " of " << runs.size() << " runs missing in " << out_dir;
  for (const auto& [shard, files] : missing_by_shard) {
    report << "\n  ";
    if (shard > 0)
      report << "shard " << shard << "/" << shard_count << " (" << files.size() << "): ";
    for (std::size_t k = 0; k < files.size(); ++k) {
      if (k == 8) {
        report << " ... and " << files.size() - k << " more";
        break;
      }
      report << (k ? ", " : "") << files[k];
    }
  }
  return report.str();
}

std::string RunOptions::validate() const {
  if (out_dir.empty()) return "the campaign's output directory (--out) is empty";
  if (threads < 0) return "threads must be >= 0 (0 = all cores), got " + std::to_string(threads);
  if (max_new_runs < 0)
    return "max_new_runs must be >= 0 (0 = no limit), got " + std::to_string(max_new_runs);
  if (!(max_wave_s >= 0.0) || !std::isfinite(max_wave_s))
    return "max_wave_s must be a finite number >= 0 (0 = no bound), got " +
           std::to_string(max_wave_s);
  if (shard.count < 0 || (shard.active() && (shard.index < 1 || shard.index > shard.count)))
    return "shard " + shard.to_string() + " is out of range; it must be i/N with 1 <= i <= N";
  if (cluster != nullptr && cluster->size() > 1 && shard.active())
    return "--shard cannot be combined with an MPI launch (the ranks share the work already)";
  if (force_new && shard.active())
    return "--force-new cannot be combined with --shard (it would delete the other shards' runs)";
  return "";
}

CampaignOutcome run_campaign(const CampaignConfig& config, const RunOptions& options) {
  const auto t_start = std::chrono::steady_clock::now();
  const fs::path dir(options.out_dir);
  const int threads = thread_count(options.threads);
  Cluster* cluster =
      options.cluster != nullptr && options.cluster->size() > 1 ? options.cluster : nullptr;
  const bool root = cluster == nullptr || cluster->rank() == 0;
  if (const std::string why = options.validate(); !why.empty()) throw std::invalid_argument(why);
  config.validate("campaign '" + config.name + "'");

  // Every path of the campaign first (a config name that cannot be a path is refused before
  // anything is written).
  const std::vector<RunSpec> runs = run_list(config, options.out_dir);
  for (std::size_t s = 0; s < config.scenarios.size(); ++s)
    optimum_file(options.out_dir, config.scenarios[s].name);

  // The manifest: rank 0 checks and writes it; every rank fails with its message (no rank is
  // left waiting for the others).
  std::string directory_error;
  DirectoryClaim claim;  // held until the campaign returns
  if (root) {
    try {
      claim = prepare_directory(config, options, threads);
    } catch (const std::exception& e) {
      directory_error = e.what();
    }
  }
  if (cluster != nullptr) directory_error = cluster->broadcast(directory_error);
  if (!directory_error.empty() && cluster != nullptr) {
    std::cerr << cluster->command() << ": error: " << directory_error << std::endl;
    cluster->sum(0);  // every rank has reported before any exits
    throw ReportedError(directory_error);
  }
  if (!directory_error.empty()) throw std::runtime_error(directory_error);
  const int shard_count = claim.shard_count;

  CampaignOutcome outcome;
  outcome.total_runs = static_cast<int>(runs.size());
  outcome.writes_results = root;
  std::vector<std::size_t> pending;  // positions in the run list this invocation should do
  if (root) {
    for (std::size_t i = 0; i < runs.size(); ++i) {
      if (!options.shard.contains(i)) continue;
      const std::string problem = run_problem(config, runs[i]);
      if (problem.empty()) {
        ++outcome.skipped_runs;
        continue;
      }
      if (problem != "missing")
        report_progress(options,
                        {.kind = ProgressEvent::Kind::kRedoingDamagedRun, .detail = problem});
      pending.push_back(i);
    }
    if (options.max_new_runs > 0 && pending.size() > static_cast<std::size_t>(options.max_new_runs))
      pending.resize(static_cast<std::size_t>(options.max_new_runs));
  }

  RunnerSettings settings;
  settings.out_dir = options.out_dir;
  settings.threads = threads;
  settings.scalar_reference = options.scalar_reference;
  settings.mpi_rank = options.cluster != nullptr;
  settings.max_wave_s = cluster == nullptr ? options.max_wave_s : 0.0;
  if (cluster == nullptr) settings.round_finished = options.round_finished;
  if (!options.quiet && root) settings.progress = options.progress;  // rank 0 reports
  std::string run_error;
  if (cluster == nullptr) {
    LockstepRunner runner(config, settings, runs, outcome.skipped_runs,
                          static_cast<int>(pending.size()));
    runner.run(pending, wave_target(threads, pending.size()), OptimumSource::kCompute);
    outcome.new_runs = runner.new_runs();
    run_error = runner.first_error();
  } else {
    outcome.skipped_runs = static_cast<int>(cluster->sum(outcome.skipped_runs));
    const std::vector<WorkUnit> units =
        root ? make_units(config, runs, pending, threads, cluster->size(), options.out_dir)
             : std::vector<WorkUnit>{};
    LockstepRunner runner(
        config, settings, runs, outcome.skipped_runs,
        static_cast<int>(cluster->sum(static_cast<std::int64_t>(pending.size()))));
    cluster->deal(units, [&](const WorkUnit& unit) {
      const std::vector<std::size_t> ids(unit.begin() + 1, unit.end());
      // The unit is one wave: its runs are scored together.
      runner.run(ids, std::numeric_limits<std::size_t>::max(),
                 unit.front() == 1 ? OptimumSource::kCompute : OptimumSource::kWait);
    });
    for (std::int64_t n : cluster->gather(runner.new_runs())) {
      outcome.new_runs_per_rank.push_back(static_cast<int>(n));
      outcome.new_runs += static_cast<int>(n);
    }
    // Every rank learns whether any failed; each reports its own error, or points to the others.
    run_error = runner.first_error();
    if (cluster->sum(run_error.empty() ? 0 : 1) > 0 && run_error.empty())
      run_error = "a run failed on another MPI rank (see its message)";
  }
  if (root && outcome.new_runs > 0)
    report_progress(options, {.kind = ProgressEvent::Kind::kRunsEnded});
  if (!run_error.empty()) throw std::runtime_error(run_error);

  // Complete when every run is there, whichever process or launch wrote it.
  if (root) {
    outcome.complete = outcome.skipped_runs + outcome.new_runs == outcome.total_runs;
    if (!outcome.complete || options.shard.active() || cluster != nullptr) {
      outcome.missing_report = missing_runs_report(options.out_dir, config, shard_count);
      outcome.complete = outcome.missing_report.empty();
    }
    if (outcome.complete) {
      const nlohmann::json summary = summarize_campaign(options.out_dir, config);
      write_file_atomic(dir / "summary.json", summary.dump(1) + "\n", own_campaign_path());
    }
  }
  if (cluster != nullptr) {
    outcome.missing_report = cluster->broadcast(outcome.missing_report);
    outcome.complete = outcome.missing_report.empty();
  }
  outcome.wall_s =
      std::chrono::duration<double>(std::chrono::steady_clock::now() - t_start).count();
  return outcome;
}

}  // namespace insid::campaign