#include "scene.h"

#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <fstream>
#include <stdexcept>
#include <unistd.h>

#include "chrono/geometry/ChTriangleMeshConnected.h"
#include "chrono_vehicle/terrain/RigidTerrain.h"
#include "chrono_vehicle/terrain/SCMTerrain.h"

using namespace chrono;
using namespace chrono::vehicle;

namespace vbref {

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

std::shared_ptr<ChContactMaterial> rigid_material(const Options& options, double friction) {
    if (options.smc) {
        auto m = chrono_types::make_shared<ChContactMaterialSMC>();
        m->SetFriction((float)friction);
        m->SetRestitution(0.01f);
        m->SetYoungModulus(2e7f);
        return m;
    }
    auto m = chrono_types::make_shared<ChContactMaterialNSC>();
    m->SetFriction((float)friction);
    m->SetRestitution(0.01f);
    return m;
}

double Ground::height(double x) const {
    return (x - x_start) * std::tan(grade_deg * CH_DEG_TO_RAD);
}

ChVector3d Ground::normal() const {
    double a = grade_deg * CH_DEG_TO_RAD;
    return ChVector3d(-std::sin(a), 0, std::cos(a));
}

ChQuaternion<> Scene::orientation(double x, double y, double yaw) const {
    ChVector3d n = normal(x, y);
    ChVector3d fwd = ChVector3d(std::cos(yaw), std::sin(yaw), 0);
    fwd -= n * Vdot(fwd, n);
    fwd.Normalize();
    return ChMatrix33<>(fwd, Vcross(n, fwd), n).GetQuaternion();
}

ChCoordsys<> Scene::start_frame(double x, double y, double yaw, double wheel_radius, double clearance) const {
    ChVector3d at(x, y, height(x, y));
    at += normal(x, y) * (wheel_radius + clearance);
    return ChCoordsys<>(at, orientation(x, y, yaw));
}

namespace {

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

class PlaneScene : public Scene {
  public:
    explicit PlaneScene(const Ground& g) : m_ground(g) {}

    void build(ChSystem& system, const Options& options) override {
        m_soil = options.soil;
        if (options.soil == Soil::Rigid) {
            auto terrain = std::make_unique<RigidTerrain>(&system);
            // A triangle mesh, as the release's rigid worlds are (a box patch gives Bullet's cylinder-box contact,
            // whose normals let a driven rigid tyre spin in place), in 10 m cells.
            std::string obj = mesh_obj(m_ground);
            terrain->AddPatch(rigid_material(options, options.rigid_friction), ChCoordsys<>(VNULL, QUNIT), obj, true,
                              0.0, false);
            std::remove(obj.c_str());
            terrain->Initialize();
            m_terrain = std::move(terrain);
            return;
        }
        auto terrain = std::make_unique<SCMTerrain>(&system, false);
        SoilSet s = soil_set(options.soil);
        terrain->SetSoilParameters(s.kphi, s.kc, s.n, s.cohesion, s.friction_deg, s.janosi, s.elastic, s.damping);
        terrain->EnableBulldozing(options.bulldozing);
        terrain->SetBulldozingParameters(55, 1, 5, 10);
        const Ground& g = m_ground;
        if (g.grade_deg == 0) {
            terrain->SetReferenceFrame(ChCoordsys<>(ChVector3d(0.5 * (g.x_start + g.x_end), 0, 0), QUNIT));
            terrain->Initialize(g.x_end - g.x_start, 2 * g.half_width, options.scm_delta);
        } else {
            // Two triangles centred on x = 0, the lowest vertex at z = 0 (SCMLoader::Initialize(trimesh) lays its
            // grid out about the mesh's centre but reads it about the frame's origin, and adds the mesh's lowest z
            // to every height it interpolates).
            ChTriangleMeshConnected mesh;
            auto& v = mesh.GetCoordsVertices();
            double w = g.half_width;
            v.push_back(ChVector3d(g.x_start, -w, 0));
            v.push_back(ChVector3d(g.x_end, -w, g.height(g.x_end)));
            v.push_back(ChVector3d(g.x_end, w, g.height(g.x_end)));
            v.push_back(ChVector3d(g.x_start, w, 0));
            auto& f = mesh.GetIndicesVertices();
            f.push_back(ChVector3i(0, 1, 2));
            f.push_back(ChVector3i(0, 2, 3));
            terrain->Initialize(mesh, options.scm_delta);
        }
        // The soil must be where the scenarios think it is (rigid: checked on the settled wheels, as a mesh patch
        // answers height queries only once the collision system runs).
        for (double px : {g.x_start + 10, 0.0, 0.5 * (g.x_start + g.x_end)}) {
            double h = terrain->GetHeight(ChVector3d(px, 0, 0));
            if (std::abs(h - g.height(px)) > 0.02)
                throw std::runtime_error("the soil's height at x = " + std::to_string(px) + " is " +
                                         std::to_string(h) + ", expected " + std::to_string(g.height(px)));
        }
        m_terrain = std::move(terrain);
    }

    void attach(ChWheeledVehicle& vehicle, const Options& options) override {
        auto* scm = dynamic_cast<SCMTerrain*>(m_terrain.get());
        if (!scm)
            return;
        for (auto& axle : vehicle.GetAxles())
            for (auto& wheel : axle->GetWheels())
                scm->AddActiveDomain(wheel->GetSpindle(), VNULL, ChVector3d(1.0, 0.6, 1.0));
        if (options.chassis_domain)
            scm->AddActiveDomain(vehicle.GetChassisBody(), VNULL, ChVector3d(5, 3, 1));
    }

    double height(double x, double) const override { return m_ground.height(x); }
    ChVector3d normal(double, double) const override { return m_ground.normal(); }
    // (As the datasheets were measured: the heading, then the grade.)
    ChQuaternion<> orientation(double, double, double yaw) const override {
        return QuatFromAngleZ(yaw) * QuatFromAngleY(-m_ground.grade_deg * CH_DEG_TO_RAD);
    }
    bool deformable() const override { return m_soil != Soil::Rigid; }
    void synchronize(double t) override { m_terrain->Synchronize(t); }
    void advance(double dt) override { m_terrain->Advance(dt); }
    ChTerrain& terrain() override { return *m_terrain; }

    void ground_force(const std::shared_ptr<ChBody>& body, ChVector3d& force, ChVector3d& torque) const override {
        if (auto* scm = dynamic_cast<SCMTerrain*>(m_terrain.get())) {
            scm->GetContactForceBody(body, force, torque);
        } else {
            force = body->GetContactForce();
            torque = body->GetContactTorque();
        }
    }

  private:
    Ground m_ground;
    Soil m_soil = Soil::Rigid;
    std::unique_ptr<ChTerrain> m_terrain;
};

}  // namespace

std::unique_ptr<Scene> plane_scene(const Ground& ground) {
    return std::make_unique<PlaneScene>(ground);
}

}  // namespace vbref
