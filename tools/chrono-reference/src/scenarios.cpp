#include "scenarios.h"

#include <algorithm>
#include <chrono>
#include <cmath>
#include <functional>
#include <iostream>

using chrono::ChVector3d;

namespace vbref {

namespace {
const double G = 9.81;

struct Clock {
    double wall = 0;
    double simulated = 0;
};
Clock g_clock;

// Adds the wall time of its scope to g_clock.
struct Timed {
    std::chrono::steady_clock::time_point start = std::chrono::steady_clock::now();
    ~Timed() { g_clock.wall += std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count(); }
};

// Runs `seconds` calling `control` (steering, throttle, brake) before every step, and `each` after it.
void drive(Rig& rig,
           double seconds,
           const std::function<void(const Rig&, double&, double&, double&)>& control,
           const std::function<bool(const Rig&)>& each = nullptr) {
    Timed timed;
    long steps = std::lround(seconds / rig.dt());
    for (long i = 0; i < steps; i++) {
        double s = 0, t = 0, b = 0;
        control(rig, s, t, b);
        rig.step(s, t, b);
        g_clock.simulated += rig.dt();
        if (each && each(rig))
            break;
    }
}

// characterize.rs's `steer`: proportional to the heading error, damped by the yaw rate.
double steer(const Rig& rig, double error) {
    return std::clamp(2 * error - 0.5 * rig.yaw_rate(), -1.0, 1.0);
}

void hold_heading_full_throttle(const Rig& rig, double& s, double& t, double& b) {
    s = steer(rig, -rig.heading());
    t = 1;
    b = 0;
}

// A settled vehicle at (x, 0) facing +x; its building and settling are counted in g_clock.
std::unique_ptr<Rig> make_rig(const Options& o, const Ground& ground, double x) {
    Timed timed;
    auto rig = std::make_unique<Rig>(o, ground, x, 0, 0);
    g_clock.simulated += rig->settle_time();
    return rig;
}

std::unique_ptr<Rig> flat_rig(const Options& o, double x) {
    return make_rig(o, Ground{}, x);
}

double mean_sinkage(const Rig& rig) {
    double sum = 0;
    int n = 0;
    for (auto& w : rig.wheels()) {
        if (w.normal > 0) {
            sum += w.sinkage;
            n++;
        }
    }
    return n ? sum / n : 0;
}

// Full throttle from rest with the heading held: speeds at 2, 5, 10, 20 s and the distance at 20 s.
void full_throttle(const Options& o, Datasheet& d) {
    auto rig = flat_rig(o, -480);
    ChVector3d x0 = rig->com();
    double marks[4] = {2, 5, 10, 20};
    double t = 0;
    for (int i = 0; i < 4; i++) {
        drive(*rig, marks[i] - t, hold_heading_full_throttle);
        t = marks[i];
        d.speed_at[i] = rig->speed();
    }
    ChVector3d dx = rig->com() - x0;
    d.distance_20s = std::hypot(dx.x(), dx.y());
}

// Mean deceleration (g) braking fully from 10 m/s to 1 m/s. sim-core sets the settled vehicle moving at 10 m/s;
// here it gets there at full throttle, then brakes.
double braking(const Options& o) {
    auto rig = flat_rig(o, -100);
    drive(*rig, 30, hold_heading_full_throttle, [](const Rig& r) { return r.speed() >= 10; });
    double v0 = rig->speed();
    double x0 = rig->com().x();
    drive(
        *rig, 10,
        [](const Rig&, double& s, double& t, double& b) {
            s = 0;
            t = 0;
            b = 1;
        },
        [](const Rig& r) { return r.speed() <= 1; });
    double d = rig->com().x() - x0;
    double v = std::max(rig->speed(), 0.0);
    if (d <= 0)
        return 0;
    return (v0 * v0 - v * v) / (2 * d) / G;
}

void sample(const Rig& rig, double grade, std::ostream& out) {
    auto w = rig.wheels();
    ChVector3d c = rig.com();
    ChVector3d fc = rig.chassis_contact_force();
    ChVector3d fs = rig.suspension_contact_force();
    ChVector3d n = rig.scene().normal(c.x(), c.y());
    for (int i = 0; i < 4; i++) {
        out << grade << ',' << rig.time() << ',' << Rig::wheel_name(i) << ',' << c.x() << ',' << c.z() << ','
            << rig.speed() << ',' << rig.gear() << ',' << rig.engine_speed() << ',' << w[i].sinkage << ','
            << w[i].slip << ',' << w[i].omega << ',' << w[i].v_fwd << ',' << w[i].normal << ',' << w[i].tractive
            << ',' << w[i].moment << ',' << chrono::Vdot(fc, n) << ',' << fc.x() << ',' << chrono::Vdot(fs, n)
            << ',' << fs.x() << '\n';
    }
}

// The tilt table: flat ground whose gravity turns 1 deg/s about the vehicle's length, uphill to its left, brakes
// on; the angle at which it slides (sideways speed above 0.05 m/s) and tips (uphill wheels under 2% of the chassis'
// weight), up to 80 degrees.
void tilt_table(const Options& o, Datasheet& d) {
    auto rig = flat_rig(o, 0);
    double weight = rig->chassis_mass() * G;
    std::optional<double> slide, tip;
    Timed timed;
    while (rig->time() < 80) {
        double deg = rig->time();
        double a = deg * chrono::CH_DEG_TO_RAD;
        rig->set_gravity(ChVector3d(0, -G * std::sin(a), -G * std::cos(a)));
        rig->step(0, 0, 1);
        g_clock.simulated += rig->dt();
        if (!slide && std::abs(rig->velocity().y()) > 0.05)
            slide = deg;
        auto w = rig->wheels();
        double uphill = std::max(w[0].normal, 0.0) + std::max(w[2].normal, 0.0);
        if (!tip && uphill < 0.02 * weight)
            tip = deg;
        if (slide && (tip || rig->time() > *slide + 5))
            break;
    }
    d.slide_angle_deg = slide;
    d.tip_angle_deg = tip;
}

// Steady turning radius at 3 m/s with constant steering: speed held by a proportional throttle and brake, radius =
// speed / yaw rate averaged over the last 5 of 25 s.
std::optional<double> turning_radius(const Options& o, double steering) {
    auto rig = flat_rig(o, 0);
    const double target = 3;
    auto control = [&](const Rig& r, double& s, double& t, double& b) {
        double e = target - r.speed();
        s = steering;
        t = std::clamp(e / target * 2, 0.0, 1.0);
        b = std::clamp(-e / target, 0.0, 1.0);
    };
    drive(*rig, 20, control);
    double speed = 0, yaw_rate = 0, n = 0;
    drive(*rig, 5, control, [&](const Rig& r) {
        ChVector3d v = r.velocity();
        speed += std::hypot(v.x(), v.y());
        yaw_rate += r.yaw_rate();
        n += 1;
        return false;
    });
    speed /= n;
    yaw_rate /= n;
    if (std::abs(yaw_rate) > 1e-6 && speed > 0.5 * target)
        return speed / std::abs(yaw_rate);
    return std::nullopt;
}

double climb_grade(const Options& o) {
    double lo = 0, hi = 60;
    if (climbs(o, hi))
        return hi;
    while (hi - lo > 0.1) {
        double mid = 0.5 * (lo + hi);
        if (climbs(o, mid))
            lo = mid;
        else
            hi = mid;
        std::cerr << "  " << soil_name(o.soil) << ": grade " << mid << (lo == mid ? " climbed" : " not climbed")
                  << std::endl;
    }
    return lo;
}
}  // namespace

void write_trace_header(std::ostream& out) {
    out << "grade_deg,t,wheel,x,z,speed,gear,engine_speed,sinkage,slip,omega,v_fwd,normal,tractive,moment,"
           "chassis_normal,chassis_fx,suspension_normal,suspension_fx\n";
}

bool climbs(const Options& o, double deg, Trace* trace) {
    Ground slope;
    slope.grade_deg = deg;
    // Centred on x = 0: SCM's mesh-initialised grid is laid out about the mesh's centre but looked up about the
    // terrain's origin.
    slope.x_start = -300;
    slope.x_end = 300;
    slope.half_width = 15;
    auto owned = make_rig(o, slope, -250);
    Rig& rig = *owned;
    double a = deg * chrono::CH_DEG_TO_RAD;
    auto along = [&](const Rig& r) { return r.com().x() / std::cos(a); };
    double x_start = along(rig);
    double next = 0;
    bool off_end = false;
    auto each = [&](const Rig& r) {
        if (trace && trace->out && r.time() + 1e-9 >= next) {
            sample(r, deg, *trace->out);
            next += trace->every;
        }
        // Past the strip's end it has climbed (the strip is 550 m long from the start).
        off_end = r.com().x() > slope.x_end - 10;
        return off_end;
    };
    drive(rig, 15, hold_heading_full_throttle, each);
    if (off_end)
        return true;
    double x15 = along(rig);
    drive(rig, 5, hold_heading_full_throttle, each);
    if (off_end)
        return true;
    ChVector3d normal = slope.normal();
    bool upright = chrono::Vdot(rig.up(), normal) > std::cos(30 * chrono::CH_DEG_TO_RAD);
    double end = along(rig);
    return upright && end - x_start >= 3 && end - x15 >= 1;
}

Datasheet datasheet(const Options& o) {
    g_clock = Clock{};
    Datasheet d;
    d.surface = soil_name(o.soil);
    d.dt = o.dt;
    {
        auto rig = flat_rig(o, 0);
        d.settle_time = rig->settle_time();
        d.static_sinkage = mean_sinkage(*rig);
        d.ride_height = rig->com().z() - rig->scene().height(rig->com().x(), rig->com().y());
    }
    std::cerr << d.surface << ": settled" << std::endl;
    full_throttle(o, d);
    std::cerr << d.surface << ": full throttle done" << std::endl;
    d.braking_decel_g = braking(o);
    std::cerr << d.surface << ": braking done" << std::endl;
    tilt_table(o, d);
    std::cerr << d.surface << ": tilt table done" << std::endl;
    d.turn_radius_half = turning_radius(o, 0.5);
    d.turn_radius_full = turning_radius(o, 1.0);
    std::cerr << d.surface << ": turning done" << std::endl;
    d.climb_grade_deg = climb_grade(o);
    d.wall_s = g_clock.wall;
    d.simulated_s = g_clock.simulated;
    return d;
}

double move_off_distance(const Options& o, const World& world, const WorldTask& task, double* wall_s) {
    double wall0 = g_clock.wall;
    double yaw = std::atan2(task.goal[1] - task.start[1], task.goal[0] - task.start[0]);
    std::unique_ptr<Rig> rig;
    {
        Timed timed;
        rig = std::make_unique<Rig>(o, world_scene(world), task.start[0], task.start[1], yaw);
    }
    ChVector3d x0 = rig->com();
    drive(*rig, 20, [&](const Rig& r, double& s, double& t, double& b) {
        ChVector3d p = r.com();
        double bearing = std::atan2(task.goal[1] - p.y(), task.goal[0] - p.x());
        double error = std::remainder(bearing - r.heading(), 2 * chrono::CH_PI);
        s = steer(r, error);
        t = 1;
        b = 0;
    });
    ChVector3d dx = rig->com() - x0;
    if (wall_s)
        *wall_s = g_clock.wall - wall0;
    return std::hypot(dx.x(), dx.y());
}

std::vector<RollBackSample> roll_back(const Options& o, double deg, double seconds) {
    Ground slope;
    slope.grade_deg = deg;
    slope.x_start = -300;
    slope.x_end = 300;
    slope.half_width = 15;
    auto rig = make_rig(o, slope, -200);
    std::vector<RollBackSample> out;
    double next = 0;
    auto record = [&](const Rig& r) {
        if (r.time() + 1e-9 >= next) {
            out.push_back({r.time(), r.speed(), r.engine_speed(), r.engine_torque(), r.gear()});
            next += 0.25;
        }
        return false;
    };
    record(*rig);
    drive(
        *rig, seconds,
        [](const Rig&, double& s, double& t, double& b) {
            s = 0;
            t = 0;
            b = 0;
        },
        record);
    return out;
}

}  // namespace vbref
