#pragma once
/// The immutable Model of the haptic step (DESIGN.md §4, STYLE.md "Model / State / step"): object
/// trees, materials, lesions, the tool, gains, device limits, capacities. Built once from a scene
/// (scene/build.hpp); the servo thread may change material parameters between steps only.

#include <cstdint>
#include <string>
#include <vector>

#include "cariesim/collision/collide.hpp"
#include "cariesim/geometry/mesh.hpp"
#include "cariesim/geometry/procedural.hpp"
#include "cariesim/spheretree/lesion.hpp"
#include "cariesim/spheretree/material.hpp"
#include "cariesim/spheretree/sphere_tree.hpp"

namespace cariesim {

/// A lesion as the engine needs it: where its caries tree is, its host tooth, its parameters.
struct LesionModel {
  std::string name;            ///< e.g. "lesion1"
  int16_t object = -1;         ///< index of its caries tree in Model::objects
  int16_t host = -1;           ///< index of the healthy tree of the same tooth
  uint16_t material = 0;       ///< index of its (top-layer) material in Model::materials
  LesionShape shape;           ///< authored shape, world coordinates
  double authored_depth = 0.0; ///< mm, depth below the surface at the shape's centre
  std::string severity;        ///< "mild", "moderate", "severe" or "" (authoring label)
};

/// The haptic tool.
struct ToolModel {
  ExplorerParams params;
  SphereTree tree;             ///< tool frame; leaf 0 is the tip sphere
  TriangleMesh display;        ///< tool frame
  double tip_radius = 0.05;    ///< mm
};

/// Virtual coupling between haptic and graphic tool: the weight G of paper eqs. 1-2.
struct CouplingGains {
  double k_trans = 1.0;   ///< N/mm (defaults to the device's maximum stiffness, eq. 6 k_p)
  double k_rot = 150.0;   ///< N·mm/rad
};

/// The device's limits (defaults: the paper's Phantom Premium 3.0 6-DoF, §4.1.2).
struct DeviceLimits {
  double max_force = 22.0;      ///< N
  double max_stiffness = 1.0;   ///< N/mm
  double max_torque = 500.0;    ///< N·mm
  double position_resolution = 0.02;  ///< mm
  Eigen::AlignedBox3d workspace{Vec3(-200, -200, -200), Vec3(200, 200, 200)};  ///< mm
};

/// Numerical settings of the step.
struct StepParams {
  double trust_step = 0.1;          ///< mm, largest tool-leaf motion per sub-step (trust region)
  double trust_rotation = 0.02;     ///< rad, largest rotation per sub-step
  int max_substeps = 6;             ///< per step; the graphic tool lags behind beyond that
  int max_rechecks = 3;             ///< collision re-checks at the solution per sub-step
  double rigid_tolerance = 0.005;   ///< mm, allowed overlap with rigid leaves at the end of a step
  double max_jump = 20.0;           ///< mm, a larger haptic jump in one step is flagged and limited
  double contact_margin = 0.02;     ///< mm, extra margin when collecting contacts
  double reference_dt = 0.001;      ///< s, eq. 5 is per 1 ms cycle; depth growth scales by dt/this
};

/// Capacities fixed at build time (scratch memory is reserved then).
struct Capacities {
  std::size_t contacts = 1024;   ///< raw sphere pairs per query
  int qp_rows = 96;              ///< rows per QP (<= kQpMaxRows)
  int friction_anchors = 8;      ///< simultaneously sticking contacts
};

/// Cold, display-only data of one scene object.
struct DisplayPart {
  std::string name;
  TriangleMesh mesh;   ///< world coordinates
  Tissue tissue = Tissue::Generic;
  int16_t lesion = -1; ///< the lesion a caries part shows, else -1
  int16_t object = -1; ///< its collision object
};

struct Model {
  std::vector<CollisionObject> objects;  ///< all collidable trees (healthy, caries, soft tissue)
  std::vector<Material> materials;
  std::vector<LesionModel> lesions;
  ToolModel tool;
  CouplingGains gains;
  DeviceLimits limits;
  StepParams params;
  Capacities capacities;
  double servo_rate = 1000.0;  ///< Hz
  Pose tool_home;              ///< a collision-free tool pose used when the state is created
  std::string scene_name;
  uint64_t scene_hash = 0;
  std::vector<DisplayPart> display;  ///< cold data for the viewer and reports
};

}  // namespace cariesim
