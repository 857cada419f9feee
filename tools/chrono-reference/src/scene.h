// What a rig drives on: the terrain(s) and obstacles a scene builds into a Chrono system, and the undeformed
// height and normal the measurements are taken against. A plane (flat or at a grade, rigid or one SCM soil) for the
// datasheet's scenarios; one of the task set's worlds (world.h) for the starts on real worlds (issue 59, item 4).
#pragma once

#include <memory>
#include <string>

#include "chrono/physics/ChBody.h"
#include "chrono/physics/ChSystem.h"
#include "chrono_vehicle/ChTerrain.h"
#include "chrono_vehicle/wheeled_vehicle/ChWheeledVehicle.h"

namespace vbref {

enum class Soil { Rigid, Snow, Mud, Sand };

Soil soil_from_name(const std::string& name);
const char* soil_name(Soil soil);

struct Options {
    Soil soil = Soil::Rigid;
    // Friction of rigid ground (concrete's mean in the release); the tyre's is 0.9 and NSC combines them as the
    // minimum.
    double rigid_friction = 0.85;
    double dt = 5e-3;
    bool smc = false;
    bool chassis_collision = true;
    bool bulldozing = true;
    // Also an SCM active domain around the chassis (5 x 3 x 1 m), so the soil meets the chassis box too; the
    // release's harness has the wheels' only.
    bool chassis_domain = false;
    double scm_delta = 0.1;
    int threads = 1;
};

// The release's SCM sets (verti_bench envs/terrain.py: Soft = snow, Mid = mud, Hard = sand).
struct SoilSet {
    double kphi, kc, n, cohesion, friction_deg, janosi, elastic, damping;
};
SoilSet soil_set(Soil soil);

// A rigid contact material of `friction` for the options' contact method (restitution 0.01, as the release's).
std::shared_ptr<chrono::ChContactMaterial> rigid_material(const Options& options, double friction);

class Scene {
  public:
    virtual ~Scene() = default;
    // Builds the terrain and obstacles into `system`.
    virtual void build(chrono::ChSystem& system, const Options& options) = 0;
    // Once the vehicle exists: the SCM active domains on its wheel spindles (and chassis, if asked).
    virtual void attach(chrono::vehicle::ChWheeledVehicle& vehicle, const Options& options) = 0;
    // The undeformed ground's height and upward unit normal at (x, y).
    virtual double height(double x, double y) const = 0;
    virtual chrono::ChVector3d normal(double x, double y) const = 0;
    // A chassis frame at (x, y) heading `yaw` (about world z) in the ground's tangent plane.
    virtual chrono::ChQuaternion<> orientation(double x, double y, double yaw) const;
    // Where the chassis' reference frame (at the wheel centres' height) starts, before settling: in the ground's
    // plane at (x, y), the wheels `clearance` above it.
    virtual chrono::ChCoordsys<> start_frame(double x, double y, double yaw, double wheel_radius,
                                             double clearance) const;
    // Whether any of the ground is SCM (a settled rigid wheel is checked against height()), and how far height()
    // may lie from the surface built (a mesh's triangles against a bilinear height).
    virtual bool deformable() const = 0;
    virtual double height_tolerance() const { return 0.05; }
    virtual void synchronize(double t) = 0;
    virtual void advance(double dt) = 0;
    // The terrain the vehicle's Synchronize reads (a rigid tyre uses it only to report its frame).
    virtual chrono::vehicle::ChTerrain& terrain() = 0;
    // The ground's (soil's or contact container's) force and torque on `body`, world frame, about its COM.
    virtual void ground_force(const std::shared_ptr<chrono::ChBody>& body, chrono::ChVector3d& force,
                              chrono::ChVector3d& torque) const = 0;
};

// A plane: z = (x - x_start) tan(grade) for x >= x_start, within [x_start, x_end] x [-half_width, half_width], of
// one ground (rigid at options.rigid_friction, or one SCM soil).
struct Ground {
    double grade_deg = 0;
    double x_start = -600;
    double x_end = 600;
    double half_width = 60;
    double height(double x) const;
    chrono::ChVector3d normal() const;
};

std::unique_ptr<Scene> plane_scene(const Ground& ground);

}  // namespace vbref
