// Typed field access for MFNS's YAML files (rig files, scenarios) with one-line errors that
// name the source, the line and the field path: "rig.yaml:12: cameras[1].intrinsics: ...".
#pragma once

#include <yaml-cpp/yaml.h>

#include <array>
#include <string>

#include "common/rig/rig.h"
#include "host/util/user_error.h"

namespace mfns::host {

// The source name and the dotted path of the field being read.
struct YamlCtx {
  std::string source;
  std::string field;

  [[noreturn]] void Fail(const YAML::Node& node, const std::string& what) const;
  YamlCtx Sub(const std::string& name) const;
  YamlCtx Index(std::size_t i) const;
};

// Parses text; a syntax error becomes a UserError with the line.
YAML::Node LoadYaml(const std::string& text, const std::string& source);

bool Has(const YAML::Node& map, const char* key);  // defined and not null
YAML::Node Require(const YAML::Node& map, const char* key, const YamlCtx& ctx);
double Number(const YAML::Node& n, const YamlCtx& ctx);  // finite
int Integer(const YAML::Node& n, const YamlCtx& ctx);
bool Boolean(const YAML::Node& n, const YamlCtx& ctx);
std::string String(const YAML::Node& n, const YamlCtx& ctx);

// Optional fields: the default when absent, else typed and checked.
double NumberOr(const YAML::Node& map, const char* key, double fallback, const YamlCtx& ctx);
int IntegerOr(const YAML::Node& map, const char* key, int fallback, const YamlCtx& ctx);
bool BooleanOr(const YAML::Node& map, const char* key, bool fallback, const YamlCtx& ctx);

template <std::size_t N>
std::array<double, N> Numbers(const YAML::Node& n, const YamlCtx& ctx) {
  if (!n.IsSequence()) ctx.Fail(n, "expected a list of " + std::to_string(N) + " numbers");
  if (n.size() != N)
    ctx.Fail(n, "expected " + std::to_string(N) + " numbers, got " + std::to_string(n.size()));
  std::array<double, N> out{};
  for (std::size_t i = 0; i < N; ++i) out[i] = Number(n[i], ctx.Index(i));
  return out;
}

// Runs parse(): a yaml-cpp exception that escapes the typed readers above (its what() is a
// bare "bad conversion" or "operator[] call on a scalar") becomes a UserError naming the source
// and the line.
template <typename F>
auto CatchYamlErrors(const std::string& source, F&& parse) -> decltype(parse()) {
  try {
    return parse();
  } catch (const YAML::Exception& e) {
    throw UserError(source + ":" + std::to_string(e.mark.line + 1) + ": " + OneLine(e.msg));
  }
}

// ValidateRig's verdict on a rig read from `root` (a rig file, or a scenario's beacons_mm) as a
// UserError naming the file, the line and the field (cameras[i].intrinsics, beacons_mm[i], ...);
// returns when the rig is valid. (Defined with the rig reader, host/rigio/rig_yaml.cc.)
void FailIfInvalid(const Rig& rig, const YAML::Node& root, const YamlCtx& ctx);

// Refuses keys of `map` not in `known` (catches typos such as "frame_rate" for
// "frame_rate_hz"), naming the first unknown key.
void RejectUnknownKeys(const YAML::Node& map, std::initializer_list<const char*> known, const YamlCtx& ctx);

}  // namespace mfns::host
