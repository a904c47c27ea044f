// A user's program against an installed cariesim (tests/install): it includes only installed
// headers, builds a scene, presses the tool into it with the step, makes a device through the
// factory and calls the recorder's and training's libraries. It prints what it did and exits 1 on
// any surprise.
#include <cariesim/common/error.hpp>
#include <cariesim/record/recorder.hpp>
#include <cariesim/render/step.hpp>
#include <cariesim/scene/model_builder.hpp>
#include <cariesim/scene/scene.hpp>
#include <cariesim/device/factory.hpp>
#include <cariesim/training/report.hpp>
#include <cariesim/training/study.hpp>
#include <cstdio>
#include <cstdlib>
#include <filesystem>
#include <memory>
#include <string>

namespace {

// Reports a failed check and ends the program.
void require(bool ok, const char* what) {
  if (ok) return;
  std::fprintf(stderr, "consumer: %s\n", what);
  std::exit(1);
}

}  // namespace

int main() {
  using namespace cariesim;
  // A 6 x 6 x 4 mm enamel block (its top face at z = 0), its tree built without the on-disk cache.
  const SceneDesc scene = parse_scene(R"(objects:
  - name: block
    shape: {type: cuboid, size: [6, 6, 4]}
    tissue: enamel
    tree: {tolerance: 0.05, max_radius: 0.8}
)",
                                      "consumer.yaml");
  BuildOptions options;
  options.use_cache = false;
  const Model model = build_model(scene, options);
  require(!model.objects.empty(), "the model has no object");

  // The step: the device moves from the home pose to 1 mm below the top face over 0.5 s at the
  // model's rate; the graphic tool stays on the surface, so the coupling pushes the device back up.
  const Params params = model.defaults;
  State state(model, model.tool_home);
  const Pose target{Vec3(0.0, 0.0, -1.0), model.tool_home.q};
  const int steps = static_cast<int>(0.5 * model.servo_rate);
  StepOutput out;
  for (int i = 1; i <= steps; ++i) {
    HapticInput in;
    in.dt = 1.0 / model.servo_rate;
    const double t = static_cast<double>(i) / steps;
    in.pose.p = (1.0 - t) * model.tool_home.p + t * target.p;
    in.pose.q = target.q;
    out = step(model, params, state, in);
    require(out.force.allFinite() && out.torque.allFinite(), "the step returned a non-finite wrench");
  }
  require(out.force.z() > 0.0, "the tool pressed into the block but is not pushed back up");
  require(out.graphic.p.z() > -0.5, "the graphic tool sank into the block");

  // A device through the factory.
  const std::unique_ptr<Device> device = make_device("null");
  require(device && device->info().name == "null", "make_device(\"null\") made no null device");

  // The recorder's library: a missing recording is a cariesim::Error naming the file.
  bool refused = false;
  try {
    (void)load_recording(std::filesystem::path("/nonexistent/cariesim-consumer.sqlite"));
  } catch (const Error& e) {
    refused = std::string(e.what()).find("cariesim-consumer.sqlite") != std::string::npos;
  }
  require(refused, "load_recording of a missing file did not throw an Error naming it");

  // Training's library: the built-in studies, and the report of no database.
  require(!training::builtin_study_names().empty(), "no built-in study");
  const training::Report report = training::build_report(training::merge_study_databases({}));
  (void)report;

  std::printf("consumer: %zu objects, upward force %.3f N after %d steps, graphic z %.3f mm, %zu studies\n",
              model.objects.size(), out.force.z(), steps, out.graphic.p.z(),
              training::builtin_study_names().size());
  return 0;
}
