#include "episodes.h"

#include <algorithm>
#include <cmath>
#include <cstdlib>
#include <chrono>
#include <cstdio>
#include <cstring>
#include <stdexcept>
#include <sys/wait.h>
#include <unistd.h>

namespace vbref {

namespace {

// A child process with its stdin and stdout on pipes.
class Child {
  public:
    explicit Child(const std::string& command) {
        int to[2], from[2];
        if (pipe(to) || pipe(from))
            throw std::runtime_error("cannot make a pipe");
        m_pid = fork();
        if (m_pid < 0)
            throw std::runtime_error("cannot fork");
        if (m_pid == 0) {
            dup2(to[0], 0);
            dup2(from[1], 1);
            close(to[0]);
            close(to[1]);
            close(from[0]);
            close(from[1]);
            execl("/bin/sh", "sh", "-c", command.c_str(), (char*)nullptr);
            _exit(127);
        }
        close(to[0]);
        close(from[1]);
        m_in = fdopen(to[1], "w");
        m_out = fdopen(from[0], "r");
        m_command = command;
    }
    ~Child() {
        if (m_in)
            fclose(m_in);
        if (m_out)
            fclose(m_out);
        int status = 0;
        waitpid(m_pid, &status, 0);
    }
    // Writes one line and reads the one answer (without its newline).
    std::string ask(const std::string& line) {
        if (std::fputs(line.c_str(), m_in) < 0 || std::fputc('\n', m_in) < 0 || std::fflush(m_in))
            throw std::runtime_error("the driver `" + m_command + "` stopped reading");
        char* buf = nullptr;
        size_t cap = 0;
        ssize_t n = getline(&buf, &cap, m_out);
        std::string answer = n > 0 ? std::string(buf, n) : std::string();
        std::free(buf);
        if (n <= 0)
            throw std::runtime_error("the driver `" + m_command + "` closed its output (its stderr says why)");
        while (!answer.empty() && (answer.back() == '\n' || answer.back() == '\r'))
            answer.pop_back();
        return answer;
    }

  private:
    pid_t m_pid = -1;
    FILE* m_in = nullptr;
    FILE* m_out = nullptr;
    std::string m_command;
};

std::string state_line(const Rig& rig, double steering) {
    double roll, pitch, yaw;
    rig.attitude(roll, pitch, yaw);
    chrono::ChVector3d p = rig.com(), v = rig.velocity(), w = rig.angular_velocity_local();
    char buf[512];
    std::snprintf(buf, sizeof buf,
                  "state %.17g %.17g %.17g %.17g %.17g %.17g %.17g %.17g %.17g %.17g %.17g %.17g %.17g %.17g %.17g",
                  rig.time(), p.x(), p.y(), p.z(), roll, pitch, yaw, v.x(), v.y(), v.z(), w.x(), w.y(), w.z(),
                  rig.speed(), steering);
    return buf;
}

bool starts_with(const std::string& s, const char* prefix) {
    return s.rfind(prefix, 0) == 0;
}

}  // namespace

EpisodeRecord drive_episode(const Options& o, const World& world, const WorldTask& task, const std::string& driver) {
    auto wall0 = std::chrono::steady_clock::now();
    EpisodeRecord r;
    r.task = task.id;
    double yaw = std::atan2(task.goal[1] - task.start[1], task.goal[0] - task.start[0]);
    Rig rig(o, world_scene(world), task.start[0], task.start[1], yaw);
    Child child(driver + " --task " + task.id);
    char dt[64];
    std::snprintf(dt, sizeof dt, "dt %.17g", o.dt);
    std::string ok = child.ask(dt);
    if (!starts_with(ok, "ok "))
        throw std::runtime_error(task.id + ": the driver answered `" + ok + "` to the step, not `ok {...}`");
    r.identity = ok.substr(3);
    double steering = 0, throttle = 0, braking = 0;
    for (;;) {
        std::string a = child.ask(state_line(rig, steering));
        if (starts_with(a, "end ")) {
            r.end_json = a.substr(4);
            break;
        }
        if (starts_with(a, "act ")) {
            if (std::sscanf(a.c_str() + 4, "%lf %lf %lf", &steering, &throttle, &braking) != 3)
                throw std::runtime_error(task.id + ": the driver's `" + a + "` is not `act S T B`");
        } else if (a != "same") {
            throw std::runtime_error(task.id + ": the driver answered `" + a + "`, not act, same or end");
        }
        if (rig.time() > 600)
            throw std::runtime_error(task.id + ": the driver did not end the episode in 600 simulated s");
        // Chrono's throttle is [0, 1] (no reverse through the pedal); the benchmark's planners never ask for less.
        rig.step(steering, std::clamp(throttle, 0.0, 1.0), braking);
    }
    r.simulated_s = rig.time();
    r.wall_s = std::chrono::duration<double>(std::chrono::steady_clock::now() - wall0).count();
    return r;
}

}  // namespace vbref
