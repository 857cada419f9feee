// chrono-reference: Chrono's HMMWV_Reduced, as Verti-Bench's release configures it, on the scenarios of
// `vb sim characterize` (issue 59). Writes JSON in `vb sim characterize --json`'s schema, or per-wheel traces.
//
//   chrono-reference datasheet [--ground rigid|snow|mud|sand|all] [VARIANT...] [--out FILE]
//   chrono-reference climb --ground G --grade DEG[,DEG...] [VARIANT...] [--trace FILE.csv]
//   chrono-reference move-off --task-dir DIR [--worlds ID[,ID...]] [VARIANT...] [--out FILE]
//   chrono-reference roll-back --grade DEG [--seconds S] [VARIANT...]
//   chrono-reference episodes --task-dir DIR --driver CMD [--worlds ID[,ID...]] [--per-world N] [--out FILE]
//
// VARIANT: --dt S (default 0.005), --smc (SMC contact instead of NSC), --no-chassis-collision,
// --no-bulldozing, --chassis-domain (an SCM domain around the chassis too), --threads N (default 1).

#include <cstdio>
#include <ctime>
#include <fstream>
#include <iostream>
#include <sstream>
#include <string>
#include <sys/utsname.h>
#include <thread>
#include <vector>
#include <cmath>

#include "chrono/ChVersion.h"
#include "episodes.h"
#include "scenarios.h"

using namespace vbref;

namespace {

std::string num(double v) {
    char buf[64];
    std::snprintf(buf, sizeof buf, "%.6g", v);
    return buf;
}

std::string opt(const std::optional<double>& v) {
    return v ? num(*v) : "null";
}

std::string cpu_model() {
    std::ifstream f("/proc/cpuinfo");
    std::string line;
    while (std::getline(f, line))
        if (line.rfind("model name", 0) == 0)
            return line.substr(line.find(':') + 2);
    return "unknown";
}

std::string today() {
    std::time_t t = std::time(nullptr);
    char buf[32];
    std::strftime(buf, sizeof buf, "%Y-%m-%d", std::gmtime(&t));
    return buf;
}

std::string json_sheet(const Datasheet& d) {
    std::ostringstream s;
    s << "    {\"vehicle\": \"hmmwv\", \"scale\": 1, \"surface\": \"" << d.surface << "\", \"dt\": " << num(d.dt)
      << ", \"settle_time\": " << num(d.settle_time) << ", \"static_sinkage\": " << num(d.static_sinkage)
      << ", \"ride_height\": " << num(d.ride_height) << ", \"speed_at\": [";
    double marks[4] = {2, 5, 10, 20};
    for (int i = 0; i < 4; i++)
        s << (i ? ", " : "") << "[" << num(marks[i]) << ", " << num(d.speed_at[i]) << "]";
    s << "], \"distance_20s\": " << num(d.distance_20s) << ", \"braking_decel_g\": " << num(d.braking_decel_g)
      << ", \"climb_grade_deg\": " << num(d.climb_grade_deg) << ", \"slide_angle_deg\": " << opt(d.slide_angle_deg)
      << ", \"tip_angle_deg\": " << opt(d.tip_angle_deg) << ", \"turn_radius_half\": " << opt(d.turn_radius_half)
      << ", \"turn_radius_full\": " << opt(d.turn_radius_full) << ", \"wall_s\": " << num(d.wall_s)
      << ", \"simulated_s\": " << num(d.simulated_s) << "}";
    return s.str();
}

std::string json_meta(const Options& o) {
    utsname u{};
    uname(&u);
    std::ostringstream s;
    s << "  \"reference\": {\"simulator\": \"Chrono " << CHRONO_VERSION << "\", \"commit\": \"" << CHRONO_COMMIT
      << "\", \"build_flags\": \"" << CHRONO_BUILD_FLAGS << "\", \"machine\": \"" << u.machine << ", "
      << cpu_model() << ", " << std::thread::hardware_concurrency() << " cores\", \"threads\": " << o.threads
      << ", \"date\": \"" << today() << "\",\n    \"config\": {\"vehicle\": \"HMMWV_Reduced\", \"contact\": \""
      << (o.smc ? "SMC" : "NSC") << "\", \"collision\": \"Bullet\", \"dt\": " << num(o.dt)
      << ", \"tyre\": \"RIGID\", \"engine\": \"SIMPLE_MAP\", \"transmission\": \"AUTOMATIC_SIMPLE_MAP\", "
         "\"drive\": \"AWD, axle and central differentials locked\", \"chassis_collision\": \""
      << (o.chassis_collision ? "PRIMITIVES" : "NONE") << "\", \"scm_delta\": " << num(o.scm_delta)
      << ", \"bulldozing\": " << (o.bulldozing ? "[55, 1, 5, 10]" : "null")
      << ", \"scm_domains\": \"" << (o.chassis_domain ? "wheels 1.0x0.6x1.0 and chassis 5x3x1" : "wheels 1.0x0.6x1.0")
      << "\", \"rigid_friction\": " << num(o.rigid_friction) << "}}";
    return s.str();
}

// To `path`, or stdout if empty.
void write_out(const std::string& path, const std::string& text) {
    if (path.empty()) {
        std::cout << text;
        return;
    }
    std::ofstream f(path);
    f << text;
    if (!f)
        throw std::runtime_error("cannot write " + path);
}

[[noreturn]] void usage(const std::string& why) {
    std::cerr << "chrono-reference: " << why
              << "\nusage: chrono-reference datasheet [--ground G|all] [--out FILE] [VARIANT...]\n"
                 "       chrono-reference climb --ground G --grade DEG[,DEG...] [--trace FILE.csv] [VARIANT...]\n"
                 "       chrono-reference move-off --task-dir DIR [--worlds ID[,ID...]] [--out FILE] [VARIANT...]\n"
                 "       chrono-reference roll-back --grade DEG [--seconds S] [VARIANT...]\n"
                 "       chrono-reference episodes --task-dir DIR --driver CMD [--worlds ID[,ID...]] [--per-world N]\n"
                 "                                 [--out FILE] [VARIANT...]\n"
                 "VARIANT: --dt S, --smc, --no-chassis-collision, --no-bulldozing, --chassis-domain, --threads N\n";
    std::exit(2);
}

double parse_number(const std::string& flag, const std::string& v) {
    try {
        size_t used = 0;
        double x = std::stod(v, &used);
        if (used == v.size() && std::isfinite(x))
            return x;
    } catch (...) {
    }
    usage(flag + " wants a number, not '" + v + "'");
}

}  // namespace

int main(int argc, char* argv[]) {
    if (argc < 2)
        usage("no command");
    std::string command = argv[1];
    Options o;
    std::string ground = "all", out, trace, task_dir, driver;
    int per_world = 0;
    std::vector<double> grades, worlds;
    double seconds = 4;
    for (int i = 2; i < argc; i++) {
        std::string a = argv[i];
        auto value = [&]() -> std::string {
            if (i + 1 >= argc)
                usage(a + " wants a value");
            return argv[++i];
        };
        if (a == "--ground")
            ground = value();
        else if (a == "--out")
            out = value();
        else if (a == "--trace")
            trace = value();
        else if (a == "--dt")
            o.dt = parse_number(a, value());
        else if (a == "--threads")
            o.threads = (int)parse_number(a, value());
        else if (a == "--smc")
            o.smc = true;
        else if (a == "--no-chassis-collision")
            o.chassis_collision = false;
        else if (a == "--no-bulldozing")
            o.bulldozing = false;
        else if (a == "--chassis-domain")
            o.chassis_domain = true;
        else if (a == "--seconds")
            seconds = parse_number(a, value());
        else if (a == "--task-dir")
            task_dir = value();
        else if (a == "--driver")
            driver = value();
        else if (a == "--per-world")
            per_world = (int)parse_number(a, value());
        else if (a == "--grade" || a == "--worlds") {
            std::stringstream list(value());
            std::string g;
            while (std::getline(list, g, ','))
                (a == "--grade" ? grades : worlds).push_back(parse_number(a, g));
        } else
            usage("unknown argument '" + a + "'");
    }
    if (!(o.dt > 0 && o.dt <= 0.02))
        usage("--dt must be in (0, 0.02] s");
    if (o.threads < 1)
        usage("--threads must be at least 1");
    try {
        if (command == "datasheet") {
            std::vector<Soil> soils;
            if (ground == "all")
                soils = {Soil::Rigid, Soil::Snow, Soil::Mud, Soil::Sand};
            else
                soils = {soil_from_name(ground)};
            std::ostringstream json;
            json << "{\n" << json_meta(o) << ",\n  \"datasheets\": [\n";
            for (size_t i = 0; i < soils.size(); i++) {
                Options oi = o;
                oi.soil = soils[i];
                Datasheet d = datasheet(oi);
                json << (i ? ",\n" : "") << json_sheet(d);
                std::cerr << json_sheet(d) << std::endl;
            }
            json << "\n  ]\n}\n";
            write_out(out, json.str());
        } else if (command == "move-off") {
            if (task_dir.empty())
                usage("move-off wants --task-dir");
            std::vector<int> ids;
            if (worlds.empty())
                ids = world_ids(task_dir);
            for (double w : worlds)
                ids.push_back((int)w);
            std::ostringstream rows, stuck;
            int starts = 0, stranded = 0;
            double wall = 0;
            for (int id : ids) {
                World world = World::load(task_dir, id);
                for (const WorldTask& t : world.tasks) {
                    double w = 0;
                    double d = move_off_distance(o, world, t, &w);
                    wall += w;
                    bool moved = d >= 5.0;
                    rows << (starts ? ",\n" : "") << "      {\"task\": \"" << t.id << "\", \"distance\": " << num(d)
                         << "}";
                    if (!moved)
                        stuck << (stranded++ ? ", " : "") << "\"" << t.id << "\"";
                    starts++;
                    std::cerr << t.id << " (" << world.semantics << "): " << num(d) << " m"
                              << (moved ? "" : " STRANDED") << ", " << num(w) << " s wall" << std::endl;
                }
            }
            std::ostringstream json;
            json << "{\n" << json_meta(o) << ",\n  \"datasheets\": [],\n  \"move_off\": {\"criterion\": "
                 << "\"full throttle towards the goal for 20 s from the settled start; moved if >= 5 m\", "
                 << "\"starts\": " << starts << ", \"wall_s\": " << num(wall) << ",\n    \"stuck\": ["
                 << stuck.str() << "],\n    \"tasks\": [\n" << rows.str() << "\n    ]\n  }\n}\n";
            write_out(out, json.str());
        } else if (command == "episodes") {
            if (task_dir.empty() || driver.empty())
                usage("episodes wants --task-dir and --driver (e.g. \"vb sim drive --task-dir DIR --release-rules\")");
            if (per_world < 0)
                usage("--per-world must be at least 0 (0: every task)");
            std::vector<int> ids;
            if (worlds.empty())
                ids = world_ids(task_dir);
            for (double w : worlds)
                ids.push_back((int)w);
            std::ostringstream rows;
            std::string identity;
            int n = 0;
            double wall = 0, simulated = 0;
            for (int id : ids) {
                World world = World::load(task_dir, id);
                int k = 0;
                for (const WorldTask& t : world.tasks) {
                    if (per_world && k++ >= per_world)
                        break;
                    EpisodeRecord r = drive_episode(o, world, t, driver);
                    if (identity.empty())
                        identity = r.identity;
                    else if (identity != r.identity)
                        throw std::runtime_error(t.id + ": the driver changed its identity to " + r.identity);
                    if (r.end_json.size() < 2 || r.end_json.front() != '{')
                        throw std::runtime_error(t.id + ": the driver's end is not a JSON object: " + r.end_json);
                    wall += r.wall_s;
                    simulated += r.simulated_s;
                    rows << (n++ ? ",\n" : "") << "      {\"task\": \"" << t.id << "\", \"wall_s\": " << num(r.wall_s)
                         << ", " << r.end_json.substr(1);
                    std::cerr << t.id << " (" << world.semantics << "): " << r.end_json << ", " << num(r.wall_s)
                              << " s wall" << std::endl;
                }
            }
            std::ostringstream json;
            json << "{\n" << json_meta(o) << ",\n  \"datasheets\": [],\n  \"episodes\": {\"driver\": "
                 << (identity.empty() ? "null" : identity) << ", \"wall_s\": " << num(wall)
                 << ", \"simulated_s\": " << num(simulated) << ",\n    \"tasks\": [\n" << rows.str()
                 << "\n    ]\n  }\n}\n";
            write_out(out, json.str());
        } else if (command == "height") {
            // The world's height at points (a self-check of the loader): --task-dir DIR --worlds N --grade X,Y,...
            if (task_dir.empty() || worlds.size() != 1 || grades.size() % 2)
                usage("height wants --task-dir, one --worlds and --grade X,Y[,X,Y...]");
            World world = World::load(task_dir, (int)worlds[0]);
            for (size_t i = 0; i < grades.size(); i += 2)
                std::cout << grades[i] << " " << grades[i + 1] << " " << world.height(grades[i], grades[i + 1])
                          << std::endl;
        } else if (command == "climb") {
            if (ground == "all" || grades.empty())
                usage("climb wants one --ground and --grade");
            o.soil = soil_from_name(ground);
            std::ofstream f;
            Trace t;
            if (!trace.empty()) {
                f.open(trace);
                if (!f)
                    throw std::runtime_error("cannot write " + trace);
                write_trace_header(f);
                t.out = &f;
            }
            for (double g : grades) {
                bool ok = climbs(o, g, trace.empty() ? nullptr : &t);
                std::cout << ground << " " << g << " deg: " << (ok ? "climbs" : "does not climb") << std::endl;
            }
        } else if (command == "roll-back") {
            if (grades.size() != 1 || !(seconds > 0 && seconds <= 60))
                usage("roll-back wants one --grade and --seconds in (0, 60]");
            o.soil = Soil::Rigid;
            std::cout << "t,speed,engine_speed,engine_torque,gear\n";
            for (const RollBackSample& r : roll_back(o, grades[0], seconds))
                std::cout << num(r.t) << ',' << num(r.speed) << ',' << num(r.engine_speed) << ','
                          << num(r.engine_torque) << ',' << r.gear << '\n';
        } else {
            usage("unknown command '" + command + "'");
        }
    } catch (const std::exception& e) {
        std::cerr << "chrono-reference: " << e.what() << std::endl;
        return 1;
    }
    return 0;
}
