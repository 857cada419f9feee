#include "world.h"

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <fstream>
#include <sstream>
#include <stdexcept>

#include "chrono/collision/ChCollisionShapeBox.h"
#include "chrono/collision/ChCollisionShapeTriangleMesh.h"
#include "chrono/geometry/ChTriangleMeshConnected.h"
#include "chrono_vehicle/terrain/SCMTerrain.h"
#include "rapidjson/document.h"
#include "stb/stb_image.h"

using namespace chrono;
using namespace chrono::vehicle;

namespace vbref {

namespace {

const int PATCHES = 16;  // per side (tasks/FORMAT.md)
const int STRIDE = 8;    // samples per patch side
// The fixed bodies' collision family (RigidTerrain's): they do not collide with each other, which Bullet would
// otherwise test mesh against mesh wherever neighbouring patches' boxes overlap.
const int FIXED_FAMILY = 14;

// SCM's grid (triangles of the 1 m cells, read at 0.1 m) against the bilinear height: (h00 + h11 - h10 - h01) / 4
// at a saddle, about a decimetre on the high worlds.
const double SOIL_HEIGHT_TOLERANCE = 0.25;
// HMMWV_Reduced's wheel centres relative to the chassis' reference frame (HMMWV_VehicleReduced.cpp: axles at +66.59
// and -66.4 in; HMMWV_DoubleWishboneReduced: spindles at 35.815 in) and its rigid tyre's width (HMMWV_RigidTire).
const double HALF_WHEELBASE = 1.689;
const double HALF_TRACK = 0.9097;
const double TYRE_WIDTH = 0.254;

void add_fixed(ChSystem& system, const std::shared_ptr<ChBody>& body) {
    body->SetFixed(true);
    body->EnableCollision(true);
    system.AddBody(body);
    body->GetCollisionModel()->SetFamily(FIXED_FAMILY);
    body->GetCollisionModel()->DisallowCollisionsWith(FIXED_FAMILY);
}

std::string read_file(const std::string& path) {
    std::ifstream f(path, std::ios::binary);
    if (!f)
        throw std::runtime_error("cannot read " + path);
    std::ostringstream s;
    s << f.rdbuf();
    return s.str();
}

rapidjson::Document parse(const std::string& path) {
    rapidjson::Document doc;
    std::string text = read_file(path);
    doc.Parse(text.c_str());
    if (doc.HasParseError())
        throw std::runtime_error(path + ": not JSON (at byte " + std::to_string(doc.GetErrorOffset()) + ")");
    return doc;
}

// Typed field access that names the file and field of what is wrong.
struct Fields {
    std::string path;
    const rapidjson::Value& get(const rapidjson::Value& v, const char* key, const std::string& where) const {
        if (!v.IsObject() || !v.HasMember(key))
            throw std::runtime_error(path + ": " + where + " has no `" + key + "`");
        return v[key];
    }
    double number(const rapidjson::Value& v, const char* key, const std::string& where) const {
        const auto& x = get(v, key, where);
        if (!x.IsNumber() || !std::isfinite(x.GetDouble()))
            throw std::runtime_error(path + ": " + where + "." + key + " is not a finite number");
        return x.GetDouble();
    }
    std::string string(const rapidjson::Value& v, const char* key, const std::string& where) const {
        const auto& x = get(v, key, where);
        if (!x.IsString())
            throw std::runtime_error(path + ": " + where + "." + key + " is not a string");
        return x.GetString();
    }
    const rapidjson::Value& array(const rapidjson::Value& v, const char* key, const std::string& where,
                                  size_t min_len = 0) const {
        const auto& x = get(v, key, where);
        if (!x.IsArray() || x.Size() < min_len)
            throw std::runtime_error(path + ": " + where + "." + key + " is not an array of at least " +
                                     std::to_string(min_len));
        return x;
    }
    void point(const rapidjson::Value& v, const char* key, const std::string& where, double out[2]) const {
        const auto& a = array(v, key, where, 2);
        for (int k = 0; k < 2; k++) {
            if (!a[k].IsNumber() || !std::isfinite(a[k].GetDouble()))
                throw std::runtime_error(path + ": " + where + "." + key + " is not a point [x, y]");
            out[k] = a[k].GetDouble();
        }
    }
};

std::string world_file(const std::string& dir, int id, const char* ext) {
    char name[32];
    std::snprintf(name, sizeof name, "/worlds/%03d.%s", id, ext);
    return dir + name;
}

// A rectangle of patches [pi0, pi1] x [pj0, pj1], inclusive.
struct Rect {
    int pi0, pi1, pj0, pj1;
};

// The largest rectangles of patches of `soil`, greedily (the release merges a world's patches of one class into the
// largest fitting rectangles): every patch of `soil` ends in exactly one.
std::vector<Rect> soil_rects(const World& w, Soil soil) {
    std::vector<bool> free(PATCHES * PATCHES);
    for (int k = 0; k < PATCHES * PATCHES; k++)
        free[k] = w.patches[k].soil == soil;
    std::vector<Rect> out;
    for (;;) {
        Rect best{0, -1, 0, -1};
        int best_area = 0;
        for (int pi0 = 0; pi0 < PATCHES; pi0++)
            for (int pj0 = 0; pj0 < PATCHES; pj0++) {
                int max_pj1 = PATCHES - 1;
                for (int pi1 = pi0; pi1 < PATCHES; pi1++) {
                    int pj1 = pj0;
                    while (pj1 <= max_pj1 && free[pi1 * PATCHES + pj1])
                        pj1++;
                    max_pj1 = pj1 - 1;
                    if (max_pj1 < pj0)
                        break;
                    int area = (pi1 - pi0 + 1) * (max_pj1 - pj0 + 1);
                    if (area > best_area) {
                        best_area = area;
                        best = {pi0, pi1, pj0, max_pj1};
                    }
                }
            }
        if (best_area == 0)
            return out;
        for (int pi = best.pi0; pi <= best.pi1; pi++)
            for (int pj = best.pj0; pj <= best.pj1; pj++)
                free[pi * PATCHES + pj] = false;
        out.push_back(best);
    }
}

// The triangle mesh of samples [ix0, ix1] x [iy0, iy1] (two triangles a cell), positions less `origin`.
std::shared_ptr<ChTriangleMeshConnected> grid_mesh(const World& w, int ix0, int ix1, int iy0, int iy1,
                                                   const ChVector3d& origin) {
    auto mesh = chrono_types::make_shared<ChTriangleMeshConnected>();
    auto& v = mesh->GetCoordsVertices();
    auto& f = mesh->GetIndicesVertices();
    int n = ix1 - ix0 + 1;
    for (int iy = iy0; iy <= iy1; iy++)
        for (int ix = ix0; ix <= ix1; ix++)
            v.push_back(ChVector3d(ix * w.cell - w.half_x(), iy * w.cell - w.half_y(), w.at(ix, iy)) - origin);
    for (int j = 0; j < iy1 - iy0; j++)
        for (int i = 0; i < ix1 - ix0; i++) {
            int a = j * n + i;
            f.push_back(ChVector3i(a, a + 1, a + n + 1));
            f.push_back(ChVector3i(a, a + n + 1, a + n));
        }
    return mesh;
}

// What the vehicle's Synchronize reads (a rigid tyre only reports its frame from it).
class WorldTerrain : public ChTerrain {
  public:
    explicit WorldTerrain(const World& w) : m_world(w) {}
    double GetHeight(const ChVector3d& loc) const override { return m_world.height(loc.x(), loc.y()); }
    ChVector3d GetNormal(const ChVector3d& loc) const override {
        double e = 0.5 * m_world.cell, x = loc.x(), y = loc.y();
        double gx = (m_world.height(x + e, y) - m_world.height(x - e, y)) / (2 * e);
        double gy = (m_world.height(x, y + e) - m_world.height(x, y - e)) / (2 * e);
        return ChVector3d(-gx, -gy, 1).GetNormalized();
    }
    float GetCoefficientFriction(const ChVector3d&) const override { return 0.8f; }

  private:
    const World& m_world;
};

class WorldScene : public Scene {
  public:
    explicit WorldScene(const World& w) : m_world(w), m_terrain(m_world) {}

    void build(ChSystem& system, const Options& options) override {
        const World& w = m_world;
        for (int pi = 0; pi < PATCHES; pi++)
            for (int pj = 0; pj < PATCHES; pj++) {
                const WorldPatch& p = w.patches[pi * PATCHES + pj];
                if (p.soil != Soil::Rigid)
                    continue;
                auto body = chrono_types::make_shared<ChBody>();
                auto mesh = grid_mesh(w, STRIDE * pj, STRIDE * (pj + 1), STRIDE * pi, STRIDE * (pi + 1), VNULL);
                body->AddCollisionShape(chrono_types::make_shared<ChCollisionShapeTriangleMesh>(
                    rigid_material(options, p.friction), mesh, true, false, 0.0));
                add_fixed(system, body);
            }
        for (Soil soil : {Soil::Snow, Soil::Mud, Soil::Sand})
            for (const Rect& r : soil_rects(w, soil))
                add_soil(system, options, soil, r);
        for (const WorldObstacle& o : w.obstacles) {
            auto body = chrono_types::make_shared<ChBody>();
            // Standing on the ground: its base at the ground's height at its centre (sim-core's convention).
            body->SetPos(ChVector3d(o.x, o.y, o.z + o.half_extents[2]));
            body->SetRot(QuatFromAngleZ(o.yaw));
            body->AddCollisionShape(chrono_types::make_shared<ChCollisionShapeBox>(
                rigid_material(options, 0.8), 2 * o.half_extents[0], 2 * o.half_extents[1], 2 * o.half_extents[2]));
            add_fixed(system, body);
        }
    }

    void attach(ChWheeledVehicle& vehicle, const Options& options) override {
        for (auto& scm : m_soils) {
            for (auto& axle : vehicle.GetAxles())
                for (auto& wheel : axle->GetWheels())
                    scm->AddActiveDomain(wheel->GetSpindle(), VNULL, ChVector3d(1.0, 0.6, 1.0));
            if (options.chassis_domain)
                scm->AddActiveDomain(vehicle.GetChassisBody(), VNULL, ChVector3d(5, 3, 1));
        }
    }

    // sim-core's placement (Simulation::place): the least-squares plane through a 5 x 5 grid of heights over the
    // footprint (wheelbase plus a wheel diameter by track plus a tyre width) gives the height and tilt, then the
    // vehicle is raised until no rim sample of any wheel starts inside the ground (the worlds' samples differ by up
    // to a metre from one cell to the next; a wheel started inside a mesh can be caught under it).
    ChCoordsys<> start_frame(double x, double y, double yaw, double r, double clearance) const override {
        const double half_l = HALF_WHEELBASE + r, half_w = HALF_TRACK + 0.5 * TYRE_WIDTH;
        double c = std::cos(yaw), s = std::sin(yaw);
        double sum = 0, su = 0, sv = 0, suu = 0, svv = 0;
        const int n = 5;
        for (int i = 0; i < n; i++)
            for (int j = 0; j < n; j++) {
                double u = (2.0 * i / (n - 1) - 1) * half_l, v = (2.0 * j / (n - 1) - 1) * half_w;
                double z = m_world.height(x + u * c - v * s, y + u * s + v * c);
                sum += z;
                su += u * z;
                sv += v * z;
                suu += u * u;
                svv += v * v;
            }
        double a = sum / (n * n), b = su / suu, d = sv / svv;
        ChVector3d fwd_h(c, s, 0), left_h(-s, c, 0);
        ChVector3d up = (ChVector3d(0, 0, 1) - fwd_h * b - left_h * d).GetNormalized();
        ChVector3d fwd = fwd_h + ChVector3d(0, 0, b);
        fwd = (fwd - up * Vdot(fwd, up)).GetNormalized();
        ChVector3d left = Vcross(up, fwd);
        ChVector3d at = ChVector3d(x, y, a) + up * r;
        double raise = 0;
        for (double wx : {HALF_WHEELBASE, -HALF_WHEELBASE})
            for (double wy : {HALF_TRACK, -HALF_TRACK}) {
                ChVector3d centre = at + fwd * wx + left * wy;
                for (int k = -7; k <= 7; k++) {
                    double phi = k * 10 * CH_DEG_TO_RAD;
                    for (double lat : {-0.5, 0.0, 0.5}) {
                        ChVector3d q = centre + (fwd * std::sin(phi) - up * std::cos(phi)) * r + left * (lat * TYRE_WIDTH);
                        raise = std::max(raise, (m_world.height(q.x(), q.y()) - q.z()) * std::cos(phi));
                    }
                }
            }
        at += up * (raise + clearance);
        return ChCoordsys<>(at, ChMatrix33<>(fwd, left, up).GetQuaternion());
    }

    double height(double x, double y) const override { return m_world.height(x, y); }
    ChVector3d normal(double x, double y) const override { return m_terrain.GetNormal(ChVector3d(x, y, 0)); }
    bool deformable() const override { return !m_soils.empty(); }
    // A settled wheel's centre over the point below it: the high worlds' samples differ by up to a metre from one
    // 1 m cell to the next, so a wheel resting on two peaks is well over R above the point between them (seen:
    // 1.6 m); the check is only against a ground built metres off.
    double height_tolerance() const override { return 3.0; }
    void synchronize(double t) override {
        for (auto& s : m_soils)
            s->Synchronize(t);
    }
    void advance(double dt) override {
        for (auto& s : m_soils)
            s->Advance(dt);
    }
    ChTerrain& terrain() override { return m_terrain; }

    void ground_force(const std::shared_ptr<ChBody>& body, ChVector3d& force, ChVector3d& torque) const override {
        // Rigid ground and obstacles through the contact container, plus every soil.
        force = body->GetContactForce();
        torque = body->GetContactTorque();
        for (auto& s : m_soils) {
            ChVector3d f, t;
            if (s->GetContactForceBody(body, f, t)) {
                force += f;
                torque += t;
            }
        }
    }

  private:
    // One SCM terrain of `soil` over the rectangle `r`: initialised from the heightmap's samples (one sample beyond
    // the rectangle where the map has one, as SCM's grid stops a grid step inside the mesh), bounded to `r`.
    void add_soil(ChSystem& system, const Options& options, Soil soil, const Rect& r) {
        const World& w = m_world;
        int ix0 = std::max(STRIDE * r.pj0 - 1, 0), ix1 = std::min(STRIDE * (r.pj1 + 1) + 1, w.nx - 1);
        int iy0 = std::max(STRIDE * r.pi0 - 1, 0), iy1 = std::min(STRIDE * (r.pi1 + 1) + 1, w.ny - 1);
        double zmin = w.at(ix0, iy0);
        for (int iy = iy0; iy <= iy1; iy++)
            for (int ix = ix0; ix <= ix1; ix++)
                zmin = std::min(zmin, w.at(ix, iy));
        // SCMLoader::Initialize(trimesh) lays its grid out about the mesh's centre but reads it about the frame's
        // origin, and adds the mesh's lowest z to every height: the mesh centred on the origin, its lowest vertex at
        // z = 0, the frame at the centre and the lowest height.
        ChVector3d centre(0.5 * (ix0 + ix1) * w.cell - w.half_x(), 0.5 * (iy0 + iy1) * w.cell - w.half_y(), zmin);
        auto mesh = grid_mesh(w, ix0, ix1, iy0, iy1, centre);
        auto scm = std::make_shared<SCMTerrain>(&system, false);
        SoilSet s = soil_set(soil);
        scm->SetSoilParameters(s.kphi, s.kc, s.n, s.cohesion, s.friction_deg, s.janosi, s.elastic, s.damping);
        scm->EnableBulldozing(options.bulldozing);
        scm->SetBulldozingParameters(55, 1, 5, 10);
        scm->SetReferenceFrame(ChCoordsys<>(centre, QUNIT));
        scm->Initialize(*mesh, options.scm_delta);
        double x0 = STRIDE * r.pj0 * w.cell - w.half_x(), x1 = STRIDE * (r.pj1 + 1) * w.cell - w.half_x();
        double y0 = STRIDE * r.pi0 * w.cell - w.half_y(), y1 = STRIDE * (r.pi1 + 1) * w.cell - w.half_y();
        scm->SetBoundary(ChAABB(ChVector3d(x0 - centre.x(), y0 - centre.y(), -1e3),
                                ChVector3d(x1 - centre.x(), y1 - centre.y(), 1e3)));
        // The soil must lie where the heightmap says (a wrong frame would put it metres off).
        for (double fx : {0.25, 0.5, 0.75}) {
            double x = x0 + fx * (x1 - x0), y = y0 + (1 - fx) * (y1 - y0);
            double h = scm->GetHeight(ChVector3d(x, y, 0));
            if (std::abs(h - w.height(x, y)) > SOIL_HEIGHT_TOLERANCE)
                throw std::runtime_error("world " + std::to_string(w.id) + ": the " + soil_name(soil) +
                                         " soil's height at (" + std::to_string(x) + ", " + std::to_string(y) +
                                         ") is " + std::to_string(h) + ", the heightmap's " +
                                         std::to_string(w.height(x, y)));
        }
        m_soils.push_back(scm);
    }

    World m_world;
    WorldTerrain m_terrain;
    std::vector<std::shared_ptr<SCMTerrain>> m_soils;
};

}  // namespace

double World::height(double x, double y) const {
    double fx = std::clamp(x / cell + 0.5 * (nx - 1), 0.0, double(nx - 1));
    double fy = std::clamp(y / cell + 0.5 * (ny - 1), 0.0, double(ny - 1));
    int ix = std::min(int(fx), nx - 2), iy = std::min(int(fy), ny - 2);
    double tx = fx - ix, ty = fy - iy;
    return (at(ix, iy) * (1 - tx) + at(ix + 1, iy) * tx) * (1 - ty) +
           (at(ix, iy + 1) * (1 - tx) + at(ix + 1, iy + 1) * tx) * ty;
}

World World::load(const std::string& dir, int id) {
    std::string path = world_file(dir, id, "json");
    rapidjson::Document doc = parse(path);
    Fields F{path};
    World w;
    w.id = (int)F.number(doc, "id", "the world");
    if (w.id != id)
        throw std::runtime_error(path + ": id is " + std::to_string(w.id) + ", expected " + std::to_string(id));
    w.semantics = F.string(doc, "semantics", "the world");
    w.cell = F.number(doc, "cell", "the world");
    double lo = F.number(doc, "height_min", "the world"), hi = F.number(doc, "height_max", "the world");
    if (!(w.cell >= 0.01 && w.cell <= 10 && lo <= hi))
        throw std::runtime_error(path + ": cell or height range out of bounds");

    std::string png = world_file(dir, id, "png");
    int width = 0, height = 0, channels = 0;
    stbi_us* px = stbi_load_16(png.c_str(), &width, &height, &channels, 1);
    if (!px)
        throw std::runtime_error(png + ": not a readable 16-bit PNG (" + stbi_failure_reason() + ")");
    if (width != PATCHES * STRIDE + 1 || height != width) {
        stbi_image_free(px);
        throw std::runtime_error(png + ": " + std::to_string(width) + " x " + std::to_string(height) +
                                 ", expected 129 x 129");
    }
    w.nx = width;
    w.ny = height;
    w.heights.resize(width * height);
    // Row 0 is the north edge: sample iy (from the south) is row ny - 1 - iy. sim-core keeps heights as f32.
    for (int iy = 0; iy < height; iy++)
        for (int ix = 0; ix < width; ix++)
            w.heights[iy * width + ix] = (float)(lo + px[(height - 1 - iy) * width + ix] / 65535.0 * (hi - lo));
    stbi_image_free(px);

    const auto& patches = F.array(doc, "patches", "the world", PATCHES * PATCHES);
    for (rapidjson::SizeType k = 0; k < PATCHES * PATCHES; k++) {
        std::string where = "patches[" + std::to_string(k) + "]";
        std::string cls = F.string(patches[k], "class", where);
        WorldPatch p;
        if (cls == "snow" || cls == "mud" || cls == "sand") {
            p.soil = soil_from_name(cls);
        } else {
            p.friction = F.number(patches[k], "friction", where);
        }
        w.patches.push_back(p);
    }
    const auto& obstacles = F.array(doc, "obstacles", "the world");
    for (rapidjson::SizeType k = 0; k < obstacles.Size(); k++) {
        std::string where = "obstacles[" + std::to_string(k) + "]";
        WorldObstacle o;
        o.kind = F.string(obstacles[k], "kind", where);
        o.x = F.number(obstacles[k], "x", where);
        o.y = F.number(obstacles[k], "y", where);
        o.z = F.number(obstacles[k], "z", where);
        o.yaw = F.number(obstacles[k], "yaw", where);
        const auto& h = F.array(obstacles[k], "half_extents", where, 3);
        for (int a = 0; a < 3; a++) {
            if (!h[a].IsNumber() || !(h[a].GetDouble() > 0))
                throw std::runtime_error(path + ": " + where + ".half_extents must be positive numbers");
            o.half_extents[a] = h[a].GetDouble();
        }
        w.obstacles.push_back(o);
    }
    const auto& tasks = F.array(doc, "tasks", "the world", 1);
    for (rapidjson::SizeType k = 0; k < tasks.Size(); k++) {
        std::string where = "tasks[" + std::to_string(k) + "]";
        WorldTask t;
        char idbuf[32];
        std::snprintf(idbuf, sizeof idbuf, "w%03d-t%d", id, (int)F.number(tasks[k], "index", where));
        t.id = idbuf;
        F.point(tasks[k], "start", where, t.start);
        F.point(tasks[k], "goal", where, t.goal);
        w.tasks.push_back(t);
    }
    return w;
}

std::vector<int> world_ids(const std::string& dir) {
    std::string path = dir + "/manifest.json";
    rapidjson::Document doc = parse(path);
    Fields F{path};
    const auto& worlds = F.array(doc, "worlds", "the manifest");
    std::vector<int> ids;
    for (rapidjson::SizeType k = 0; k < worlds.Size(); k++)
        ids.push_back((int)F.number(worlds[k], "id", "worlds[" + std::to_string(k) + "]"));
    return ids;
}

std::unique_ptr<Scene> world_scene(const World& world) {
    return std::make_unique<WorldScene>(world);
}

}  // namespace vbref
