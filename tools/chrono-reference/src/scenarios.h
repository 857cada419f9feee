// The scenarios of `vb sim characterize` (sim-core/src/characterize.rs), run on the Chrono rig by the same
// criteria: settle, full-throttle speeds and 20 s distance, braking from 10 m/s, the steepest grade, the tilt table's
// slide and tip, the steady turning radii. Full-size HMMWV: the scale is 1.
#pragma once

#include <optional>
#include <ostream>
#include <string>
#include <vector>

#include "rig.h"
#include "world.h"

namespace vbref {

struct Datasheet {
    std::string surface;
    double dt = 0;
    double settle_time = 0;
    double static_sinkage = 0;
    double ride_height = 0;
    double speed_at[4] = {0, 0, 0, 0};  // at 2, 5, 10, 20 s
    double distance_20s = 0;
    double braking_decel_g = 0;
    double climb_grade_deg = 0;
    std::optional<double> slide_angle_deg, tip_angle_deg;
    std::optional<double> turn_radius_half, turn_radius_full;
    // Wall time and simulated time of every run of the datasheet, s.
    double wall_s = 0;
    double simulated_s = 0;
};

// Per-wheel, chassis and suspension samples every `every` s, as CSV (one row per wheel per sample).
struct Trace {
    std::ostream* out = nullptr;
    double every = 0.05;
};

Datasheet datasheet(const Options& options);

// Whether the vehicle climbs `grade_deg` by characterize.rs's criterion; writes the run to `trace` if given.
bool climbs(const Options& options, double grade_deg, Trace* trace = nullptr);

void write_trace_header(std::ostream& out);

// sim-core's move-off check (sim-core/src/move_off.rs): from `task`'s start of `world`, settled facing the goal,
// full throttle for 20 s with the steering holding the bearing to the goal; how far (m, horizontal) the chassis
// ends from where it started. `wall_s` gets the wall time of the run.
double move_off_distance(const Options& options, const World& world, const WorldTask& task, double* wall_s = nullptr);

// A coasting stop's roll-back (issue 59): settled with the brakes on facing up a rigid `grade_deg` plane, in
// first gear, then throttle and brakes released for `seconds`; one sample every 0.25 s. Chrono's transmission gives
// the engine |driveshaft speed| / gear ratio and the driveline the engine's signed torque / gear ratio, so the
// closed-throttle map's drag, always negative in a forward gear, pushes a vehicle rolling backwards.
struct RollBackSample {
    double t, speed, engine_speed, engine_torque;
    int gear;
};
std::vector<RollBackSample> roll_back(const Options& options, double grade_deg, double seconds);

}  // namespace vbref
