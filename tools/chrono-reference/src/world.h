// One world of a task set (tasks/FORMAT.md: worlds/NNN.json and its 16-bit heightmap NNN.png), as `vb tasks
// import-verti-bench` writes the release's worlds, built into Chrono as the release builds it (envs/terrain.py):
// rigid patches as triangle meshes of the heightmap's samples with their own friction, deformable patches as SCM
// terrains of their soil set over the largest rectangles of one soil (each bounded to its rectangle, the wheels'
// active domains on every one), obstacles as fixed boxes of their half extents standing on the ground.
#pragma once

#include <string>
#include <vector>

#include "scene.h"

namespace vbref {

struct WorldPatch {
    Soil soil = Soil::Rigid;  // Rigid: a rigid class of `friction`
    double friction = 0;
};

struct WorldObstacle {
    std::string kind;  // rock or tree
    double x = 0, y = 0, z = 0, yaw = 0;
    double half_extents[3] = {0, 0, 0};
};

struct WorldTask {
    std::string id;  // w001-t3
    double start[2] = {0, 0};
    double goal[2] = {0, 0};
};

struct World {
    int id = 0;
    std::string semantics;
    double cell = 1;
    int nx = 0, ny = 0;
    std::vector<double> heights;  // heights[iy * nx + ix], iy from south, ix from west
    std::vector<WorldPatch> patches;  // patches[pi * 16 + pj], pi from south, pj from west
    std::vector<WorldObstacle> obstacles;
    std::vector<WorldTask> tasks;

    // Loads worlds/NNN.json of the task set in `dir` and its heightmap; throws std::runtime_error naming the file
    // and field of anything missing or malformed.
    static World load(const std::string& dir, int id);

    double half_x() const { return 0.5 * (nx - 1) * cell; }
    double half_y() const { return 0.5 * (ny - 1) * cell; }
    double at(int ix, int iy) const { return heights[iy * nx + ix]; }
    // Bilinear between samples, clamped to the map's edge (sim-core's Heightmap::height_bilinear).
    double height(double x, double y) const;
};

// The ids of the worlds listed by the task set's manifest.json, in its order.
std::vector<int> world_ids(const std::string& dir);

std::unique_ptr<Scene> world_scene(const World& world);

}  // namespace vbref
