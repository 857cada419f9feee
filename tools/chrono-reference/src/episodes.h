// Whole episodes on a task set's worlds (issue 59, item 4): Chrono's HMMWV driven by a planner on the other end of a
// pipe, `vb sim drive` (eval/src/external.rs), which runs the benchmark's own planner and judges the episode by the
// benchmark's own rules, so only the vehicle and the terrain are Chrono's.
#pragma once

#include <string>

#include "rig.h"
#include "world.h"

namespace vbref {

struct EpisodeRecord {
    std::string task;
    std::string end_json;   // the driver's `end` object (outcome, reason, detail, time, steps, ...)
    std::string identity;   // the driver's `ok` object (planner, rules, control_every)
    double wall_s = 0;      // building, settling and driving, s
    double simulated_s = 0; // after settling, s
};

// Runs `driver` (a shell command; ` --task ID` is appended) for `task` of `world`: the vehicle settled at the start
// facing the goal, then one physics step after another with the driver's inputs until it ends the episode. Throws
// std::runtime_error if the driver breaks the protocol or never ends it (10 simulated minutes).
EpisodeRecord drive_episode(const Options& options, const World& world, const WorldTask& task,
                            const std::string& driver);

}  // namespace vbref
