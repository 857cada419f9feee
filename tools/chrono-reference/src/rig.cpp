#include "rig.h"

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <fstream>
#include <unistd.h>
#include <stdexcept>

#include "chrono/geometry/ChTriangleMeshConnected.h"
#include "chrono/physics/ChSystemNSC.h"
#include "chrono/physics/ChSystemSMC.h"
#include "chrono_vehicle/terrain/RigidTerrain.h"
#include "chrono_vehicle/terrain/SCMTerrain.h"

using namespace chrono;
using namespace chrono::vehicle;
using namespace chrono::vehicle::hmmwv;

namespace vbref {

namespace {
const double G = 9.81;
const double TYRE_RADIUS = 0.467;  // HMMWV_RigidTire::m_radius
// Settling, as sim-core's Simulation::settle: gravity ramped up smoothly over LOAD_RAMP, then still (every part
// slower than SETTLED_SPEED) for SETTLED_FOR, at most SETTLE_MAX in all.
const double LOAD_RAMP = 2.0;
const double SETTLED_SPEED = 2e-3;
const double SETTLED_FOR = 1.0;
const double SETTLE_MAX = 10.0;

}  // namespace

Rig::Rig(const Options& options, const Ground& ground, double x, double y, double yaw)
    : Rig(options, plane_scene(ground), x, y, yaw) {}

Rig::Rig(const Options& options, std::unique_ptr<Scene> scene, double x, double y, double yaw)
    : m_options(options), m_scene(std::move(scene)) {
    if (options.smc)
        m_system = std::make_unique<ChSystemSMC>();
    else
        m_system = std::make_unique<ChSystemNSC>();
    m_system->SetCollisionSystemType(ChCollisionSystem::Type::BULLET);
    m_system->SetGravitationalAcceleration(ChVector3d(0, 0, -G));
    m_system->SetNumThreads(options.threads, options.threads, 1);
    m_scene->build(*m_system, options);

    m_hmmwv = std::make_unique<HMMWV_Reduced>(m_system.get());
    m_hmmwv->SetContactMethod(options.smc ? ChContactMethod::SMC : ChContactMethod::NSC);
    m_hmmwv->SetChassisCollisionType(options.chassis_collision ? CollisionType::PRIMITIVES : CollisionType::NONE);
    m_hmmwv->SetChassisFixed(false);
    m_hmmwv->SetEngineType(EngineModelType::SIMPLE_MAP);
    m_hmmwv->SetTransmissionType(TransmissionModelType::AUTOMATIC_SIMPLE_MAP);
    m_hmmwv->SetDriveType(DrivelineTypeWV::AWD);
    m_hmmwv->SetTireType(TireModelType::RIGID);
    m_hmmwv->SetTireStepSize(options.dt);
    // The chassis' reference frame is at the wheel centres' height: put the wheels 3 cm above the ground, the
    // chassis in the ground's plane there.
    ChCoordsys<> start = m_scene->start_frame(x, y, yaw, TYRE_RADIUS, 0.03);
    ChVector3d at = start.pos;
    m_hmmwv->SetInitPosition(start);
    m_hmmwv->Initialize();
    m_hmmwv->LockAxleDifferential(0, true);
    m_hmmwv->LockAxleDifferential(1, true);
    m_hmmwv->LockCentralDifferential(0, true);
    m_hmmwv->LockCentralDifferential(1, true);
    m_hmmwv->GetVehicle().EnableRealtime(false);

    m_scene->attach(m_hmmwv->GetVehicle(), options);
    m_settle_time = settle();
    // (Unless it slid away while settling, as on a slope steeper than it can stand on.)
    ChVector3d moved = com() - at;
    if (!m_scene->deformable() && std::hypot(moved.x(), moved.y()) < 1.0) {
        for (auto& w : wheels())
            if (std::abs(w.sinkage) > m_scene->height_tolerance())
                throw std::runtime_error("a settled wheel is " + std::to_string(-w.sinkage) +
                                         " m off the rigid ground's expected surface (the chassis at " +
                                         std::to_string(com().x()) + ", " + std::to_string(com().y()) + ", " +
                                         std::to_string(com().z()) + ")");
    }
    m_t0 = m_system->GetChTime();
}

Rig::~Rig() = default;

double Rig::settle() {
    ChVector3d g(0, 0, -G);
    double still = 0;
    double t = 0;
    auto& vehicle = m_hmmwv->GetVehicle();
    while (t < SETTLE_MAX && (still < SETTLED_FOR || t < LOAD_RAMP)) {
        double r = std::min(t / LOAD_RAMP, 1.0);
        set_gravity(g * (r * r * (3 - 2 * r)));
        step(0, 0, 1);
        t += m_options.dt;
        double moving = vehicle.GetChassisBody()->GetPosDt().Length();
        for (auto& axle : vehicle.GetAxles())
            for (auto& wheel : axle->GetWheels())
                moving = std::max(moving, wheel->GetSpindle()->GetPosDt().Length());
        still = moving < SETTLED_SPEED ? still + m_options.dt : 0;
    }
    set_gravity(g);
    return t;
}

void Rig::step(double steering, double throttle, double braking) {
    DriverInputs in;
    in.m_steering = steering;
    in.m_throttle = throttle;
    in.m_braking = braking;
    in.m_clutch = 0;
    double t = m_system->GetChTime();
    m_scene->synchronize(t);
    m_hmmwv->Synchronize(t, in, m_scene->terrain());
    m_scene->advance(m_options.dt);
    m_hmmwv->Advance(m_options.dt);
    m_system->DoStepDynamics(m_options.dt);
}

double Rig::time() const {
    return m_system->GetChTime() - m_t0;
}

ChVector3d Rig::com() const {
    return m_hmmwv->GetChassisBody()->GetPos();
}

ChVector3d Rig::velocity() const {
    return m_hmmwv->GetChassisBody()->GetPosDt();
}

ChVector3d Rig::up() const {
    return m_hmmwv->GetChassisBody()->GetRotMat().GetAxisZ();
}

double Rig::heading() const {
    ChVector3d x = m_hmmwv->GetChassisBody()->GetRotMat().GetAxisX();
    return std::atan2(x.y(), x.x());
}

double Rig::yaw_rate() const {
    return m_hmmwv->GetChassisBody()->GetAngVelParent().z();
}

double Rig::speed() const {
    return m_hmmwv->GetVehicle().GetSpeed();
}

void Rig::attitude(double& roll, double& pitch, double& yaw) const {
    const auto& R = m_hmmwv->GetChassisBody()->GetRotMat();
    roll = std::atan2(R(2, 1), R(2, 2));
    pitch = std::asin(std::clamp(-R(2, 0), -1.0, 1.0));
    yaw = std::atan2(R(1, 0), R(0, 0));
}

ChVector3d Rig::angular_velocity_local() const {
    return m_hmmwv->GetChassisBody()->GetAngVelLocal();
}

double Rig::chassis_mass() const {
    return m_hmmwv->GetChassisBody()->GetMass();
}

void Rig::set_gravity(const ChVector3d& g) {
    m_system->SetGravitationalAcceleration(g);
}

const char* Rig::wheel_name(int i) {
    static const char* names[4] = {"front_left", "front_right", "rear_left", "rear_right"};
    return names[i];
}

ChVector3d Rig::body_contact_force(const std::shared_ptr<ChBody>& body) const {
    ChVector3d force, torque;
    m_scene->ground_force(body, force, torque);
    return force;
}

std::array<WheelSample, 4> Rig::wheels() const {
    std::array<WheelSample, 4> out{};
    auto& vehicle = m_hmmwv->GetVehicle();
    for (int i = 0; i < 4; i++) {
        int axle = i / 2;
        VehicleSide side = (i % 2 == 0) ? LEFT : RIGHT;
        auto spindle = vehicle.GetWheel(axle, side)->GetSpindle();
        ChVector3d pos = spindle->GetPos();
        ChVector3d n = m_scene->normal(pos.x(), pos.y());
        // The chassis' left axis: a forward-rolling wheel spins positively about it.
        ChVector3d axis = vehicle.GetChassisBody()->GetRotMat().GetAxisY();
        ChVector3d fwd = Vcross(axis, n);
        fwd.Normalize();
        ChVector3d force, torque;
        m_scene->ground_force(spindle, force, torque);
        WheelSample& w = out[i];
        w.sinkage = TYRE_RADIUS - (pos.z() - m_scene->height(pos.x(), pos.y())) * n.z();
        w.omega = Vdot(spindle->GetAngVelParent(), axis);
        w.v_fwd = Vdot(spindle->GetPosDt(), fwd);
        double rim = w.omega * TYRE_RADIUS;
        if (std::abs(rim) < 1e-3 && std::abs(w.v_fwd) < 1e-3)
            w.slip = 0;
        else if (std::abs(rim) >= std::abs(w.v_fwd))
            w.slip = 1 - w.v_fwd / rim;
        else
            w.slip = (rim - w.v_fwd) / std::abs(w.v_fwd);
        w.normal = Vdot(force, n);
        w.tractive = Vdot(force, fwd);
        w.moment = Vdot(torque, axis);
    }
    return out;
}

ChVector3d Rig::chassis_contact_force() const {
    return body_contact_force(m_hmmwv->GetChassisBody());
}

ChVector3d Rig::suspension_contact_force() const {
    auto& vehicle = m_hmmwv->GetVehicle();
    std::vector<ChBody*> excluded{vehicle.GetChassisBody().get()};
    for (auto& axle : vehicle.GetAxles())
        for (auto& wheel : axle->GetWheels())
            excluded.push_back(wheel->GetSpindle().get());
    ChVector3d sum(0);
    for (auto& body : m_system->GetBodies())
        if (!body->IsFixed() && std::find(excluded.begin(), excluded.end(), body.get()) == excluded.end())
            sum += body_contact_force(body);
    return sum;
}

int Rig::gear() const {
    return m_hmmwv->GetVehicle().GetTransmission()->GetCurrentGear();
}

double Rig::engine_speed() const {
    return m_hmmwv->GetVehicle().GetEngine()->GetMotorSpeed();
}

double Rig::engine_torque() const {
    return m_hmmwv->GetVehicle().GetEngine()->GetOutputMotorshaftTorque();
}

}  // namespace vbref
