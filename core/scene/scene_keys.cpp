#include "core/scene/scene_keys.h"

namespace kgd {

const std::vector<SceneKey>& SceneKeys() {
#define KGD_SCENE_KEY_ROW(section, key, what) SceneKey{#section, #key, what},
  static const std::vector<SceneKey> keys = {KGD_SCENE_KEYS(KGD_SCENE_KEY_ROW)};
#undef KGD_SCENE_KEY_ROW
  return keys;
}

std::vector<std::string> SceneKeysOf(const std::string& section) {
  std::vector<std::string> out;
  for (const SceneKey& k : SceneKeys())
    if (section == k.section) out.push_back(k.key);
  return out;
}

}  // namespace kgd
