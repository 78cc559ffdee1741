// The report's fidelity section (fidelity.h): loads its scenes, measures each
// (fidelity_measure.cpp) and writes its text (fidelity_markdown.cpp).
#include "report/fidelity.h"

#include <cstdio>
#include <filesystem>
#include <optional>
#include <string>
#include <vector>

#include "report/fidelity_internal.h"

namespace shrefract::report {

using namespace fidelity;  // the section's parts (fidelity_internal.h)

BakeSettings defaultFieldSettings() {
  BakeSettings s;
  s.encoding = Encoding::Pca;  // where the scene is not a volume (bake::settingsForScene)
  s.order = 0;
  s.layout = SampleLayout::Charts;  // the tool's default
  s.pathRule = PathRule::FirstRefraction;
  s.tryVolume = true;  // the scene decides the encoding, as `shrefract bake SCENE` with no flags
  s.sampleBudget = 0;  // and the budget its encoding affords
  return s;
}

Result<FidelityResult> runFidelity(const FidelityOptions& options, offscreen::Session& session,
                                   std::vector<std::string>& files) {
  const auto start = Clock::now();
  const Profile profile = profileFor(options.size, options.samples);
  const uint32_t width = options.width ? options.width : profile.width;
  const uint32_t height = options.height ? options.height : profile.height;
  const std::vector<std::string> specs = options.scenes.empty() ? profile.scenes : options.scenes;

  // Load every scene first: input errors before minutes of work. A default scene whose asset is
  // missing is skipped.
  std::vector<std::optional<bake::Scene>> scenes;
  FidelityResult result;
  for (const std::string& spec : specs) {
    FidelityScene placeholder;
    placeholder.scene = spec;
    if (options.scenes.empty() && spec == kBunny && !std::filesystem::exists(spec)) {
      placeholder.skipped = spec + " not found from the working directory (run from the repository root with "
                                   "../shared/assets present)";
      std::fprintf(stderr, "report: fidelity: %s\n", placeholder.skipped.c_str());
      scenes.emplace_back();
    } else {
      auto scene = cli::loadScene(spec, {}, nullptr);
      if (!scene) return scene.error();
      scenes.emplace_back(std::move(scene).value());
    }
    result.scenes.push_back(placeholder);
  }

  const bake::Image environment = bake::proceduralEnvironment(profile.environmentWidth);
  auto gpuEnvironment = offscreen::uploadEnvironment(session, environment);
  if (!gpuEnvironment) return gpuEnvironment.error();
  for (size_t i = 0; i < specs.size(); ++i) {
    if (!scenes[i]) continue;
    auto tracer = bake::Tracer::create(*scenes[i]);
    if (!tracer) return makeError(tracer.error().code, specs[i] + ": " + tracer.error().message);
    SceneContext c{profile, options, session, *gpuEnvironment.value(), environment, files, specs[i], *scenes[i],
                   *tracer.value()};
    c.name = sanitize(sceneTitle(specs[i]));
    c.width = width;
    c.height = height;
    c.frames = options.frames ? options.frames : profile.frames;
    c.camera = offscreen::defaultCamera(*scenes[i]);
    auto measured = measureScene(c);
    if (!measured) return measured.error();
    result.scenes[i] = std::move(measured).value();
    std::fprintf(stderr, "report: fidelity: %s done in %.1f s\n", specs[i].c_str(), result.scenes[i].seconds);
  }
  result.markdown = markdownOf(profile, result.scenes, width, height, since(start));
  return result;
}

}  // namespace shrefract::report
