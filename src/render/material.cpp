#include "cariesim/render/material.hpp"

#include <algorithm>
#include <array>

namespace cariesim {

namespace {
constexpr std::array<std::string_view, 6> kTissueNames{"enamel", "dentin", "caries",
                                                       "gingiva", "tongue", "generic"};
}  // namespace

std::string_view tissue_name(Tissue tissue) { return kTissueNames[static_cast<std::size_t>(tissue)]; }

bool parse_tissue(std::string_view name, Tissue& out) {
  for (std::size_t i = 0; i < kTissueNames.size(); ++i) {
    if (kTissueNames[i] == name) {
      out = static_cast<Tissue>(i);
      return true;
    }
  }
  return false;
}

// k_c over insertion depth: constant, stepwise layers, or a linear gradient (paper Fig. 6).
double KcProfile::at(double depth_mm) const {
  constexpr double kMinKc = 1e-6;  // N/mm; keeps eq. 5's division finite
  double k = values[0];
  switch (kind) {
    case Kind::Constant:
      break;
    case Kind::Layers: {
      const int n = std::clamp(layer_count, 1, kMaxLayers);
      k = values[n - 1];
      for (int i = 0; i < n; ++i) {
        if (depth_mm < bounds[i]) {
          k = values[i];
          break;
        }
      }
      break;
    }
    case Kind::Gradient: {
      const double span = bounds[0] > 0.0 ? bounds[0] : 1.0;
      const double t = std::clamp(depth_mm / span, 0.0, 1.0);
      k = values[0] + (values[1] - values[0]) * t;
      break;
    }
  }
  return std::max(k, kMinKc);
}

// The averages of the five dentists' tuned values (paper Tables 1 and 2). The paper gives F_p* only
// qualitatively (large for mild, small for severe, §3.1); ours are chosen in that spirit and are
// scene-editable. k_e enters the entry and extraction criteria (eqs. 3-4, 8). The surface stiffness
// in sliding is not k_e: a surface that soft (0.4-0.5 N/mm in series with the 1 N/mm coupling)
// lets the tip sink by F_p*/k_e² before |F_p| reaches F_p*, i.e. through the whole lesion, so the
// penetration state would never start. Caries is softer than enamel (rigid) but firm enough that
// the tip sinks at most a few tenths of a millimetre at F_p* (0.13 mm mild, 0.5 mm severe).
Material caries_preset(CariesPreset preset) {
  Material m;
  m.tissue = Tissue::Caries;
  const bool mild = preset == CariesPreset::Mild;
  m.mu_s = mild ? 0.18 : 0.51;
  m.mu_d = mild ? 0.17 : 0.45;
  m.k_e = mild ? 0.53 : 0.38;
  m.stiffness = mild ? 30.0 : 4.0;  // N/mm
  m.k_c.kind = KcProfile::Kind::Constant;
  m.k_c.values.fill(mild ? 0.58 : 0.20);
  m.crush_length = 3.0;  // mm: resistance k_c·3 mm = 1.74 N mild, 0.60 N severe (below F_p*)
  m.f_p_star = mild ? 2.0 : 0.8;
  m.f_e_star = mild ? 1.0 : 0.5;
  return m;
}

}  // namespace cariesim
