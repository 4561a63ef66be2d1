// Edits of a configuration's YAML text for the benchmarks' --set and --serial-link options: line
// edits that keep the file's comments and layout (the configurations are block style, as
// config/sim-lab.yaml). Pure string functions.
#pragma once

#include <algorithm>
#include <sstream>
#include <string>
#include <vector>

namespace motion::bench {

// Sets KEY: VALUE under the configuration's top-level `simulation:` map (block style, as in
// config/sim-lab.yaml), replacing the key's line when it has one; a new section when there is none.
inline void set_simulation_key(std::string& yaml, const std::string& key, const std::string& value) {
  std::vector<std::string> lines;
  std::istringstream in(yaml);
  for (std::string line; std::getline(in, line);) lines.push_back(line);
  const std::string line = "  " + key + ": " + value;
  const auto section = std::find(lines.begin(), lines.end(), "simulation:");
  if (section == lines.end()) {
    lines.emplace_back("simulation:");
    lines.push_back(line);
  } else {
    auto at = section + 1;
    for (; at != lines.end() && at->rfind("  ", 0) == 0; ++at) {
      if (at->rfind("  " + key + ":", 0) == 0) break;
    }
    if (at != lines.end() && at->rfind("  " + key + ":", 0) == 0)
      *at = line;
    else
      lines.insert(section + 1, line);
  }
  yaml.clear();
  for (const auto& l : lines) yaml += l + "\n";
}

// Sets KEY: VALUE in the entry of `buses:` whose `- name:` is BUS, in the configuration's text
// (`spec` is BUS.KEY=VALUE): the key's line when the entry has one, else a new line after the
// name. Returns what was wrong with `spec`, empty when it applied.
inline std::string set_bus_key(std::string& yaml, const std::string& spec) {
  const auto dot = spec.find('.');
  const auto eq = spec.find('=');
  if (dot == std::string::npos || eq == std::string::npos || eq < dot || dot == 0 || eq == dot + 1)
    return "--set wants BUS.KEY=VALUE, got '" + spec + "'";
  const std::string bus = spec.substr(0, dot);
  const std::string key = spec.substr(dot + 1, eq - dot - 1);
  const std::string value = spec.substr(eq + 1);
  std::vector<std::string> lines;
  std::istringstream in(yaml);
  for (std::string line; std::getline(in, line);) lines.push_back(line);
  const auto indent = [](const std::string& l) { return l.find_first_not_of(' '); };
  const auto name_of = [&](const std::string& l) -> std::string {  // "  - name: can0   # ..." -> can0
    const auto at = indent(l);
    if (at == std::string::npos || l.compare(at, 8, "- name: ") != 0) return {};
    std::string rest = l.substr(at + 8);
    rest = rest.substr(0, rest.find('#'));
    while (!rest.empty() && rest.back() == ' ') rest.pop_back();
    return rest;
  };
  std::size_t entry = 0;
  bool in_buses = false;
  for (; entry < lines.size(); ++entry) {
    if (lines[entry].rfind("buses:", 0) == 0)
      in_buses = true;
    else if (!lines[entry].empty() && indent(lines[entry]) == 0)
      in_buses = false;
    if (in_buses && name_of(lines[entry]) == bus) break;
  }
  if (entry == lines.size()) return "--set " + spec + ": no bus '" + bus + "' under buses:";
  const std::size_t key_indent = indent(lines[entry]) + 2;
  std::size_t at = entry + 1;
  for (; at < lines.size(); ++at) {
    const auto i = indent(lines[at]);
    if (i == std::string::npos) continue;
    if (i < key_indent) break;  // the next entry, or the next section
    if (i == key_indent && lines[at].compare(i, key.size() + 1, key + ":") == 0) break;
  }
  const std::string line = std::string(key_indent, ' ') + key + ": " + value;
  if (at < lines.size() && indent(lines[at]) == key_indent &&
      lines[at].compare(key_indent, key.size() + 1, key + ":") == 0)
    lines[at] = line;
  else
    lines.insert(lines.begin() + static_cast<std::ptrdiff_t>(entry) + 1, line);
  yaml.clear();
  for (const auto& l : lines) yaml += l + "\n";
  return {};
}

}  // namespace motion::bench
