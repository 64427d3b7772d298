// insid merge: write the summary of a campaign or sweep directory filled by shards.
#include <iostream>
#include <memory>
#include <string>

#include "bench/sweep.h"
#include "cli/commands.h"

namespace insid::cli {

void add_merge_command(CLI::App& app) {
  auto dir = std::make_shared<std::string>();
  CLI::App* cmd = app.add_subcommand(
      "merge",
      "Once every run of the campaign (or sweep) in DIR is there, whichever shards or MPI ranks "
      "wrote them, write summary.json (and a sweep's sweep.json, sweep.csv); otherwise fail, "
      "listing the missing runs by shard.");
  cmd->add_option("DIR", *dir, "results directory (holds manifest.json)")->required();
  cmd->callback([dir] {
    const int runs = campaign::merge_results(*dir);
    std::cerr << "insid merge: all " << runs << " runs present; summary written to " << *dir
              << "/summary.json\n";
  });
}

}  // namespace insid::cli
