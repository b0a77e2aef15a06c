#include "locd/sdk/plugin_config.hpp"

#include <cstdlib>
#include <regex>

namespace locd {

void check_plugin_name(const std::string& name, const std::string& what) {
  if (name.find('/') != std::string::npos || name.find('.') != std::string::npos) {
    throw ConfigError(what + ": plugin '" + name + "': plugin must be a name, not a path");
  }
  static const std::regex valid_name("[a-z][a-z0-9_]{0,63}");
  if (!std::regex_match(name, valid_name)) {
    throw ConfigError(what + ": plugin '" + name + "' is not a valid plugin name; expected [a-z][a-z0-9_]*");
  }
}

PluginConfig split_plugin_config(const Params& document, const std::string& source_name) {
  document.expect_only({"plugin", "params", "ros2", "server_group"});
  if (!document.has("plugin")) {
    throw ConfigError(source_name + ": key 'plugin' is missing; expected 'plugin: <name>' and 'params:'");
  }
  const std::string plugin = document.required_text("plugin");
  check_plugin_name(plugin, source_name + " (" + document.where("plugin") + ")");
  std::optional<Ros2Config> ros2;
  if (document.has("ros2")) ros2 = parse_ros2_config(document.child("ros2"));
  const std::string group = document.text("server_group", "");
  if (group.size() > 64) document.fail("server_group", "is longer than 64 characters");
  if (!document.has("params")) return {plugin, Params(YAML::Node(YAML::NodeType::Map), plugin), ros2, group};
  const YAML::Node params = document.node()["params"];
  if (!params.IsMap()) document.fail("params", "is not a map; expected the plugin's parameters as 'key: value' lines");
  return {plugin, Params(params, plugin), ros2, group};
}

PluginConfig split_plugin_config(const std::string& yaml_text, const std::string& source_name) {
  return split_plugin_config(Params::parse(yaml_text, source_name), source_name);
}

PluginConfig split_plugin_config(const PluginConfigText& text) {
  if (text.path.empty()) return split_plugin_config(text.yaml, text.source);
  Params node = Params::parse(text.yaml, text.source);
  // Walks the keys as the server's config parser named them: "sessions[2].config".
  std::string name;
  for (const auto& key : text.path) {
    YAML::Node child;
    if (node.node().IsSequence()) {
      char* end = nullptr;
      const unsigned long index = std::strtoul(key.c_str(), &end, 10);
      if (key.empty() || *end != '\0' || index >= node.node().size()) {
        throw ConfigError(text.source + ": no entry " + key + " under '" + name + "'");
      }
      child = node.node()[index];
      name += "[" + key + "]";
    } else if (node.node().IsMap() && node.node()[key]) {
      child = node.node()[key];
      name += (name.empty() ? "" : ".") + key;
    } else {
      throw ConfigError(text.source + ": no key '" + key + "' under '" + name + "'");
    }
    node = Params(child, name);
  }
  if (!node.node().IsMap()) throw ConfigError(text.source + ": '" + name + "' is not a map; expected 'plugin: <name>' and 'params:'");
  return split_plugin_config(node, text.source);
}

}  // namespace locd
