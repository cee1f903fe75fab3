#pragma once
/// \file
/// The scene registry: every scene a client can load, in the order of
/// scene.list, `hapticd --list-scenes` and docs/scenes.md. An entry names a
/// scene's description (world/<name>_scene.cpp: parameters, what it needs
/// from the device, how the gate judges it, its factory) and its RT types
/// (`alternatives`), so this one list also makes world::AnyScene. Adding a
/// scene: docs/scenes.md "Adding a scene".

#include "world/chirp_scene.hpp"
#include "world/free_scene.hpp"
#include "world/relay_scene.hpp"
#include "world/spring_scene.hpp"
#include "world/task_scenes.hpp"
#include "world/wall_scene.hpp"

namespace hapticd::world {

template <class... Entries>
struct SceneList {};

using SceneRegistry = SceneList<SpringWheelEntry, SpringMassEntry, WallEntry, RelayEntry, ChirpEntry,
                                FreeEntry, PlaneWallEntry, SphereEntry, BoxEntry, AxisSpringsEntry>;

}  // namespace hapticd::world
