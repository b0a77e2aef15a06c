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

namespace {

// A Nav2 params file: `amcl.ros__parameters` are grid_mcl's parameters (AMCL's names) with AMCL's
// ROS keys moved to the ros2 section (parse_nav2_amcl); the map is map_server's yaml_filename
// unless the amcl section names one; `ros2` and `server_group` may stand beside them. The sections
// of other Nav2 nodes (`<node>: {ros__parameters: ...}`) configure those nodes, not locd: skipped.
PluginConfig split_nav2_params(const Params& document, const std::string& source_name) {
  for (const auto& item : document.node()) {
    const std::string key = item.first.as<std::string>();
    if (key == "amcl" || key == "map_server" || key == "ros2" || key == "server_group") continue;
    if (item.second.IsMap() && item.second["ros__parameters"]) continue;
    const YAML::Mark m = item.first.Mark();
    throw ConfigError(source_name + ": key '" + key + "' (line " + std::to_string(m.line + 1) +
                      ") in a Nav2 params file is neither amcl, map_server, ros2, server_group nor another Nav2 "
                      "node's section (<node>: {ros__parameters: ...})");
  }
  const Params amcl = document.child("amcl");
  amcl.expect_only({"ros__parameters"});
  if (!amcl.node()["ros__parameters"] || !amcl.node()["ros__parameters"].IsMap()) {
    document.fail("amcl", "has no ros__parameters map; expected amcl: {ros__parameters: {alpha1: 0.2, ...}} as in "
                          "Nav2's nav2_params.yaml");
  }
  const Params params(amcl.node()["ros__parameters"], "amcl.ros__parameters");
  const Params section = document.child("ros2");
  const Ros2Config ros2 = parse_nav2_amcl(params, document.has("ros2") ? &section : nullptr);
  if (!params.has("map")) {
    const Params map_server = document.child("map_server").child("ros__parameters");
    if (!map_server.has("yaml_filename")) {
      throw ConfigError(source_name + ": no map: give map_server.ros__parameters.yaml_filename (the map YAML map_server "
                                      "loads, in the server's map directories) or amcl.ros__parameters.map");
    }
    YAML::Node(params.node())["map"] = map_server.node()["yaml_filename"];
  }
  const std::string group = document.text("server_group", "");
  if (group.size() > 64) document.fail("server_group", "is longer than 64 characters");
  return {"grid_mcl", params, ros2, group};
}

}  // namespace

PluginConfig split_plugin_config(const Params& document, const std::string& source_name) {
  if (document.has("amcl")) return split_nav2_params(document, source_name);
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
