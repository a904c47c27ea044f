#pragma once
/// The haptic step's materials: tissue label, contact stiffness, friction and, for caries, the
/// penetration parameters of the paper (eqs. 3-9, Fig. 6, Tables 1-2). One type for healthy tissue
/// and lesions alike, from the scene description (scene/scene_desc.hpp) to the running Params
/// (render/params.hpp). A sphere-tree leaf carries only an index into the model's table of them
/// (SphereNode::material); docs/penetration.md says how the step uses them.

#include <array>
#include <cstdint>
#include <limits>
#include <string_view>

#include "cariesim/common/math.hpp"

namespace cariesim {

enum class Tissue : uint8_t { Enamel, Dentin, Caries, Gingiva, Tongue, Generic };

/// Name used in scene files and reports ("enamel", "dentin", ...).
std::string_view tissue_name(Tissue tissue);
/// Parses a tissue name; returns false when unknown.
bool parse_tissue(std::string_view name, Tissue& out);

/// Penetration stiffness k_c over insertion depth (paper Fig. 6).
struct KcProfile {
  enum class Kind : uint8_t { Constant, Layers, Gradient };
  static constexpr int kMaxLayers = 4;
  Kind kind = Kind::Constant;
  /// Constant: values[0]. Layers: values[i] holds from depth bounds[i-1] (0 for i = 0) to bounds[i].
  /// Gradient: linear from values[0] at depth 0 to values[1] at depth bounds[0].
  std::array<double, kMaxLayers> values{10.0, 10.0, 10.0, 10.0};  ///< N/mm
  std::array<double, kMaxLayers> bounds{0.0, 0.0, 0.0, 0.0};      ///< mm, layer bottoms
  int layer_count = 1;

  /// k_c at an insertion depth (mm); always > 0.
  [[nodiscard]] double at(double depth_mm) const;
};

/// A material of the model's table (Params::materials, indexed by SphereNode::material). Healthy tissue
/// is frictionless unless its material sets mu (paper eq. 2); its caries fields keep their defaults.
struct Material {
  Tissue tissue = Tissue::Generic;
  /// Contact stiffness (N/mm); infinity means rigid (no penetration allowed).
  double stiffness = std::numeric_limits<double>::infinity();
  double mu_s = 0.0;  ///< static friction coefficient (across `aniso_dir` when anisotropic)
  double mu_d = 0.0;  ///< dynamic friction coefficient (across `aniso_dir` when anisotropic)
  /// Anisotropic friction (paper §2.1): along `aniso_dir` (projected on the contact plane) the
  /// coefficients are mu_s_along / mu_d_along. A zero vector means isotropic.
  Vec3 aniso_dir = Vec3::Zero();
  double mu_s_along = 0.0;
  double mu_d_along = 0.0;
  // Caries only (lesion materials):
  double k_e = 0.5;  ///< N/mm, contact stiffness in eqs. 4 and 8
  KcProfile k_c;     ///< N/mm, penetration stiffness over depth, eq. 5
  /// mm, crush length: the tissue ahead of the tip resists its advance with k_c(depth)·crush_length
  /// (docs/penetration.md; our reading of eq. 5, which makes k_c felt at a hand's speed).
  /// The base (k_c 10 N/mm) resists with 2 N, below its F_p* of 3 N; the presets use 3 mm.
  double crush_length = 0.2;
  double f_p_star = 3.0;   ///< N, insertion threshold F_p*, eq. 5
  double f_e_star = 1.0;   ///< N, extraction threshold F_e*, eq. 9
  double k_theta = 100.0;  ///< N·mm/rad, rotational stiffness of the tunnel, eq. 7
  int16_t lesion = -1;     ///< index of the lesion this material belongs to, -1 for none

  [[nodiscard]] bool rigid() const { return !(stiffness < std::numeric_limits<double>::infinity()); }
  [[nodiscard]] bool frictional() const { return mu_s > 0.0 || mu_s_along > 0.0; }
};

/// The paper's expert-tuned presets (Tables 1-2): mild mu_s 0.18 mu_d 0.17 k_c 0.58 k_e 0.53;
/// severe mu_s 0.51 mu_d 0.45 k_c 0.20 k_e 0.38. F_p* is large for mild, small for severe (§3.1).
enum class CariesPreset : uint8_t { Mild, Severe };
/// Fills a caries material from a preset (friction, k_e, constant k_c, F_p*, F_e*).
Material caries_preset(CariesPreset preset);

}  // namespace cariesim
