// The registry entry of `free` (world/scene_registry.hpp): no parameters,
// nothing to judge, nothing asked of the device.

#include "world/free_scene.hpp"

#include "world/scene_catalog.hpp"

namespace hapticd::world {

namespace {

void build_free(ScenePlan& plan, const SceneContext& context) {
  set_scene(plan, FreeScene{}, context.motion);
  if (context.axes > 1) set_task_scene(plan, TaskFreeScene{});
}

}  // namespace

SceneDescription FreeEntry::describe() {
  return {.name = "free",
          .reference = "Freudenberg 3 (released device)",
          .summary = "zero output",
          .parameters = {},
          .fixed_motion = std::nullopt,
          .stability = StabilityRule::none,
          .unstable_hint = {},
          .build = build_free,
          .space = SceneSpace::any};
}

}  // namespace hapticd::world
