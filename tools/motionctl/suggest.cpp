// Suggestions for misspelt subcommands and axis names (motionctl.hpp).
#include <algorithm>

#include "motionctl.hpp"

namespace motion::ctl {
namespace {

// Edit distance with adjacent transpositions (optimal string alignment): insert, delete,
// substitute, swap two neighbours; one step each ("mvoe" is 1 from "move").
std::size_t edit_distance(const std::string& a, const std::string& b) {
  std::vector<std::vector<std::size_t>> d(a.size() + 1, std::vector<std::size_t>(b.size() + 1));
  for (std::size_t i = 0; i <= a.size(); ++i) d[i][0] = i;
  for (std::size_t j = 0; j <= b.size(); ++j) d[0][j] = j;
  for (std::size_t i = 1; i <= a.size(); ++i) {
    for (std::size_t j = 1; j <= b.size(); ++j) {
      const std::size_t substitution = a[i - 1] == b[j - 1] ? std::size_t{0} : std::size_t{1};
      d[i][j] = std::min({d[i - 1][j] + 1, d[i][j - 1] + 1, d[i - 1][j - 1] + substitution});
      if (i > 1 && j > 1 && a[i - 1] == b[j - 2] && a[i - 2] == b[j - 1])
        d[i][j] = std::min(d[i][j], d[i - 2][j - 2] + 1);
    }
  }
  return d[a.size()][b.size()];
}

}  // namespace

std::string did_you_mean(const std::string& word, const std::vector<std::string>& names) {
  const std::size_t limit = std::max<std::size_t>(1, word.size() / 3);
  const std::string* best = nullptr;
  std::size_t best_distance = limit + 1;
  for (const auto& name : names) {
    const std::size_t d = edit_distance(word, name);
    if (d < best_distance && d < word.size()) {  // never a whole word replaced ('q' is no 'x')
      best = &name;
      best_distance = d;
    }
  }
  return best != nullptr ? "; did you mean '" + *best + "'?" : std::string();
}

std::string unknown_subcommand(const CLI::App& cli, int argc, const char* const* argv) {
  std::vector<std::string> names;
  for (const auto* sub : cli.get_subcommands([](const CLI::App*) { return true; })) names.push_back(sub->get_name());
  for (int i = 1; i < argc; ++i) {
    const std::string arg = argv[i];
    if (arg == "--") return {};
    if (!arg.empty() && arg[0] == '-') {
      // A global option with a separate value (--config FILE) takes the next word with it.
      const auto* option = arg.find('=') == std::string::npos ? cli.get_option_no_throw(arg) : nullptr;
      if (option != nullptr && option->get_items_expected_min() > 0) ++i;
      continue;
    }
    if (std::find(names.begin(), names.end(), arg) != names.end()) return {};
    return "unknown command '" + arg + "'" + did_you_mean(arg, names);
  }
  return {};
}

std::string unknown_axis(const config::Config& config, const std::string& axis) {
  if (config.find_axis(axis) != nullptr) return {};
  std::vector<std::string> names;
  std::string all;
  for (const auto& a : config.axes) {
    names.push_back(a.name);
    all += (all.empty() ? "" : ", ") + a.name;
  }
  const auto hint = did_you_mean(axis, names);
  return "unknown axis '" + axis + "'" + (hint.empty() ? " (axes of " + config.file + ": " + all + ")" : hint);
}

std::vector<std::string> unknown_axes(const config::Config& config, const motionlcm::request_t& request) {
  std::vector<std::string> out;
  for (const auto& axis : request.axes) {
    if (auto error = unknown_axis(config, axis); !error.empty()) out.push_back(std::move(error));
  }
  return out;
}

}  // namespace motion::ctl
