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

// The ground as a Wavefront OBJ file of 10 m cells in a fresh temporary file; returns its path.
std::string mesh_obj(const Ground& g) {
    char path[] = "/tmp/chrono-reference-ground-XXXXXX.obj";
    int fd = mkstemps(path, 4);
    if (fd < 0)
        throw std::runtime_error("cannot create a temporary mesh file");
    close(fd);
    std::ofstream f(path);
    int nx = (int)std::ceil((g.x_end - g.x_start) / 10), ny = (int)std::ceil(2 * g.half_width / 10);
    for (int i = 0; i <= nx; i++)
        for (int j = 0; j <= ny; j++) {
            double x = g.x_start + (g.x_end - g.x_start) * i / nx;
            double y = -g.half_width + 2 * g.half_width * j / ny;
            f << "v " << x << ' ' << y << ' ' << g.height(x) << '\n';
        }
    auto id = [&](int i, int j) { return i * (ny + 1) + j + 1; };
    for (int i = 0; i < nx; i++)
        for (int j = 0; j < ny; j++) {
            f << "f " << id(i, j) << ' ' << id(i + 1, j) << ' ' << id(i + 1, j + 1) << '\n';
            f << "f " << id(i, j) << ' ' << id(i + 1, j + 1) << ' ' << id(i, j + 1) << '\n';
        }
    if (!f)
        throw std::runtime_error(std::string("cannot write ") + path);
    return path;
}
}  // namespace

Soil soil_from_name(const std::string& name) {
    if (name == "rigid")
        return Soil::Rigid;
    if (name == "snow")
        return Soil::Snow;
    if (name == "mud")
        return Soil::Mud;
    if (name == "sand")
        return Soil::Sand;
    throw std::invalid_argument("unknown ground '" + name + "' (rigid, snow, mud or sand)");
}

const char* soil_name(Soil soil) {
    switch (soil) {
        case Soil::Rigid:
            return "rigid";
        case Soil::Snow:
            return "snow";
        case Soil::Mud:
            return "mud";
        case Soil::Sand:
            return "sand";
    }
    return "?";
}

SoilSet soil_set(Soil soil) {
    switch (soil) {
        case Soil::Snow:
            return {0.2e6, 0, 1.1, 0, 30, 0.01, 4e7, 3e4};
        case Soil::Mud:
            return {2e6, 0, 1.1, 0, 30, 0.01, 2e8, 3e4};
        case Soil::Sand:
            return {5301e3, 102e3, 0.793, 1.3e3, 31.1, 0.012, 4e8, 3e4};
        case Soil::Rigid:
            break;
    }
    throw std::invalid_argument("rigid ground has no soil set");
}

double Ground::height(double x) const {
    return (x - x_start) * std::tan(grade_deg * CH_DEG_TO_RAD);
}

ChVector3d Ground::normal() const {
    double a = grade_deg * CH_DEG_TO_RAD;
    return ChVector3d(-std::sin(a), 0, std::cos(a));
}

Rig::Rig(const Options& options, const Ground& ground, double x, double y, double yaw)
    : m_options(options), m_ground(ground) {
    if (options.smc)
        m_system = std::make_unique<ChSystemSMC>();
    else
        m_system = std::make_unique<ChSystemNSC>();
    m_system->SetCollisionSystemType(ChCollisionSystem::Type::BULLET);
    m_system->SetGravitationalAcceleration(ChVector3d(0, 0, -G));
    m_system->SetNumThreads(options.threads, options.threads, 1);

    double a = ground.grade_deg * CH_DEG_TO_RAD;
    ChQuaternion<> slope = QuatFromAngleY(-a);
    double length = ground.x_end - ground.x_start;
    if (options.soil == Soil::Rigid) {
        auto terrain = std::make_unique<RigidTerrain>(m_system.get());
        std::shared_ptr<ChContactMaterial> mat;
        if (options.smc) {
            auto m = chrono_types::make_shared<ChContactMaterialSMC>();
            m->SetFriction((float)options.rigid_friction);
            m->SetRestitution(0.01f);
            m->SetYoungModulus(2e7f);
            mat = m;
        } else {
            auto m = chrono_types::make_shared<ChContactMaterialNSC>();
            m->SetFriction((float)options.rigid_friction);
            m->SetRestitution(0.01f);
            mat = m;
        }
        // A triangle mesh, as the release's rigid worlds are (a box patch gives Bullet's cylinder-box contact,
        // whose normals let a driven rigid tyre spin in place), in 10 m cells.
        std::string obj = mesh_obj(ground);
        terrain->AddPatch(mat, ChCoordsys<>(VNULL, QUNIT), obj, true, 0.0, false);
        std::remove(obj.c_str());
        terrain->Initialize();
        m_terrain = std::move(terrain);
    } else {
        auto terrain = std::make_unique<SCMTerrain>(m_system.get(), false);
        SoilSet s = soil_set(options.soil);
        terrain->SetSoilParameters(s.kphi, s.kc, s.n, s.cohesion, s.friction_deg, s.janosi, s.elastic, s.damping);
        terrain->EnableBulldozing(options.bulldozing);
        terrain->SetBulldozingParameters(55, 1, 5, 10);
        if (ground.grade_deg == 0) {
            terrain->SetReferenceFrame(ChCoordsys<>(ChVector3d(0.5 * (ground.x_start + ground.x_end), 0, 0), QUNIT));
            terrain->Initialize(length, 2 * ground.half_width, options.scm_delta);
        } else {
            // Two triangles; the lowest vertex at z = 0 (SCMLoader::Initialize(trimesh) adds the mesh's lowest z to
            // every height it interpolates).
            ChTriangleMeshConnected mesh;
            auto& v = mesh.GetCoordsVertices();
            double w = ground.half_width;
            v.push_back(ChVector3d(ground.x_start, -w, 0));
            v.push_back(ChVector3d(ground.x_end, -w, ground.height(ground.x_end)));
            v.push_back(ChVector3d(ground.x_end, w, ground.height(ground.x_end)));
            v.push_back(ChVector3d(ground.x_start, w, 0));
            auto& f = mesh.GetIndicesVertices();
            f.push_back(ChVector3i(0, 1, 2));
            f.push_back(ChVector3i(0, 2, 3));
            terrain->Initialize(mesh, options.scm_delta);
        }
        m_scm = true;
        m_terrain = std::move(terrain);
    }
    // The ground must be where the scenarios think it is (rigid: checked on the settled wheels below, as a mesh
    // patch answers height queries only once the collision system runs).
    for (double px : {x, 0.5 * (ground.x_start + ground.x_end)}) {
        if (!m_scm)
            break;
        double h = m_terrain->GetHeight(ChVector3d(px, y, 0));
        if (std::abs(h - ground.height(px)) > 0.02)
            throw std::runtime_error("the terrain's height at x = " + std::to_string(px) + " is " + std::to_string(h) +
                                     ", expected " + std::to_string(ground.height(px)));
    }

    m_hmmwv = std::make_unique<HMMWV_Reduced>(m_system.get());
    m_hmmwv->SetContactMethod(options.smc ? ChContactMethod::SMC : ChContactMethod::NSC);
    m_hmmwv->SetChassisCollisionType(options.chassis_collision ? CollisionType::PRIMITIVES : CollisionType::NONE);
    m_hmmwv->SetChassisFixed(false);
    m_hmmwv->SetEngineType(EngineModelType::SIMPLE_MAP);
    m_hmmwv->SetTransmissionType(TransmissionModelType::AUTOMATIC_SIMPLE_MAP);
    m_hmmwv->SetDriveType(DrivelineTypeWV::AWD);
    m_hmmwv->SetTireType(TireModelType::RIGID);
    m_hmmwv->SetTireStepSize(options.dt);
    // The chassis' reference frame is at the wheel centres' height: put the wheels 3 cm above the ground.
    ChVector3d at(x, y, ground.height(x));
    at += ground.normal() * (TYRE_RADIUS + 0.03);
    m_hmmwv->SetInitPosition(ChCoordsys<>(at, QuatFromAngleZ(yaw) * slope));
    m_hmmwv->Initialize();
    m_hmmwv->LockAxleDifferential(0, true);
    m_hmmwv->LockAxleDifferential(1, true);
    m_hmmwv->LockCentralDifferential(0, true);
    m_hmmwv->LockCentralDifferential(1, true);
    m_hmmwv->GetVehicle().EnableRealtime(false);

    if (m_scm) {
        auto* scm = static_cast<SCMTerrain*>(m_terrain.get());
        auto& vehicle = m_hmmwv->GetVehicle();
        for (auto& axle : vehicle.GetAxles())
            for (auto& wheel : axle->GetWheels())
                scm->AddActiveDomain(wheel->GetSpindle(), VNULL, ChVector3d(1.0, 0.6, 1.0));
        if (m_options.chassis_domain)
            scm->AddActiveDomain(vehicle.GetChassisBody(), VNULL, ChVector3d(5, 3, 1));
    }
    m_settle_time = settle();
    // (Unless it slid away while settling, as on a slope steeper than it can stand on.)
    ChVector3d moved = com() - at;
    if (!m_scm && std::hypot(moved.x(), moved.y()) < 1.0) {
        for (auto& w : wheels())
            if (std::abs(w.sinkage) > 0.05)
                throw std::runtime_error("a settled wheel is " + std::to_string(-w.sinkage) +
                                         " m off the rigid ground's expected surface");
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
    m_terrain->Synchronize(t);
    m_hmmwv->Synchronize(t, in, *m_terrain);
    m_terrain->Advance(m_options.dt);
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

void Rig::ground_force(const std::shared_ptr<ChBody>& body, ChVector3d& force, ChVector3d& torque) const {
    if (m_scm) {
        static_cast<SCMTerrain*>(m_terrain.get())->GetContactForceBody(body, force, torque);
    } else {
        force = body->GetContactForce();
        torque = body->GetContactTorque();
    }
}

ChVector3d Rig::body_contact_force(const std::shared_ptr<ChBody>& body) const {
    ChVector3d force, torque;
    ground_force(body, force, torque);
    return force;
}

std::array<WheelSample, 4> Rig::wheels() const {
    std::array<WheelSample, 4> out{};
    auto& vehicle = m_hmmwv->GetVehicle();
    ChVector3d n = m_ground.normal();
    double cos_a = std::cos(m_ground.grade_deg * CH_DEG_TO_RAD);
    for (int i = 0; i < 4; i++) {
        int axle = i / 2;
        VehicleSide side = (i % 2 == 0) ? LEFT : RIGHT;
        auto spindle = vehicle.GetWheel(axle, side)->GetSpindle();
        ChVector3d pos = spindle->GetPos();
        // The chassis' left axis: a forward-rolling wheel spins positively about it.
        ChVector3d axis = vehicle.GetChassisBody()->GetRotMat().GetAxisY();
        ChVector3d fwd = Vcross(axis, n);
        fwd.Normalize();
        ChVector3d force, torque;
        ground_force(spindle, force, torque);
        WheelSample& w = out[i];
        w.sinkage = TYRE_RADIUS - (pos.z() - m_ground.height(pos.x())) * cos_a;
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

}  // namespace vbref
