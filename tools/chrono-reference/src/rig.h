// The test rig: Chrono's HMMWV_Reduced configured as Verti-Bench's release runs it (NSC contact, Bullet collision,
// 5 ms step, RIGID tyres, AWD with both axle differentials and the central differential locked, SIMPLE_MAP engine,
// AUTOMATIC_SIMPLE_MAP transmission, primitive chassis collision box), on rigid ground or on SCM with one of the
// release's three soil sets (0.1 m grid, bulldozing 55 deg / 1 / 5 / 10, one active domain 1.0 x 0.6 x 1.0 m per
// wheel spindle), on a scene (scene.h: a plane, or one of the task set's worlds); variants of the release's
// configuration (SMC contact, another step, no chassis collision, no bulldozing) separate causes (issue 59, item 3).
#pragma once

#include <array>
#include <memory>
#include <string>
#include <vector>

#include "chrono/core/ChVector3.h"
#include "chrono_models/vehicle/hmmwv/HMMWV.h"
#include "scene.h"

namespace vbref {

// One wheel at one instant. Forces are the soil's (or rigid ground's) on the wheel, world frame, split along the
// ground's normal and the wheel's heading in the ground's plane.
struct WheelSample {
    double sinkage;  // m, along the ground's normal below its undeformed surface (rigid: penetration, ~0)
    double slip;     // 1 - v / (omega r) when driving, (omega r - v) / v when braking; 0 at rest
    double omega;    // spin, rad/s
    double v_fwd;    // centre speed along the wheel's heading, m/s
    double normal;   // N
    double tractive; // N, along the heading
    double moment;   // N m, the soil's moment about the axle (negative resists a forward spin)
};

class Rig {
  public:
    // Builds the system, the scene and the vehicle at (x, y) facing yaw, resting on the ground; then settles it
    // (settle()).
    Rig(const Options& options, std::unique_ptr<Scene> scene, double x, double y, double yaw);
    // On a plane.
    Rig(const Options& options, const Ground& ground, double x, double y, double yaw);
    ~Rig();

    // One step with these inputs (steering +1 turns left).
    void step(double steering, double throttle, double braking);
    // Time since the vehicle settled, s.
    double time() const;
    double settle_time() const { return m_settle_time; }
    double dt() const { return m_options.dt; }

    chrono::ChVector3d com() const;       // the chassis' centre of mass
    chrono::ChVector3d velocity() const;  // of the chassis' centre of mass
    chrono::ChVector3d up() const;        // the chassis' up axis
    double heading() const;               // yaw of the chassis' x axis, rad
    double yaw_rate() const;              // world z angular velocity, rad/s
    double speed() const;                 // forward speed of the chassis, m/s
    // Cardan angles of the chassis, R = Rz(yaw) Ry(pitch) Rx(roll) (sim-core's VehicleState), rad.
    void attitude(double& roll, double& pitch, double& yaw) const;
    chrono::ChVector3d angular_velocity_local() const;  // in the chassis frame, rad/s
    double chassis_mass() const;
    void set_gravity(const chrono::ChVector3d& g);

    std::array<WheelSample, 4> wheels() const;  // front left, front right, rear left, rear right
    static const char* wheel_name(int i);
    // The soil's or ground's force on the chassis, and on every other body but the spindles, world frame.
    chrono::ChVector3d chassis_contact_force() const;
    chrono::ChVector3d suspension_contact_force() const;
    int gear() const;
    double engine_speed() const;  // rad/s
    double engine_torque() const; // N m at the motorshaft (negative: the closed-throttle map's drag)

    const Scene& scene() const { return *m_scene; }

  private:
    double settle();
    chrono::ChVector3d body_contact_force(const std::shared_ptr<chrono::ChBody>& body) const;

    Options m_options;
    std::unique_ptr<Scene> m_scene;
    std::unique_ptr<chrono::ChSystem> m_system;
    std::unique_ptr<chrono::vehicle::hmmwv::HMMWV_Reduced> m_hmmwv;
    double m_t0 = 0;
    double m_settle_time = 0;
};

}  // namespace vbref
