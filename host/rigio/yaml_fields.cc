#include "host/rigio/yaml_fields.h"

#include <cmath>
#include <cstring>
#include <sstream>

namespace mfns::host {

void YamlCtx::Fail(const YAML::Node& node, const std::string& what) const {
  std::ostringstream ss;
  ss << source;
  if (node.IsDefined() && node.Mark().line >= 0) ss << ":" << node.Mark().line + 1;
  ss << ": " << (field.empty() ? "" : field + ": ") << OneLine(what);
  throw UserError(ss.str());
}

YamlCtx YamlCtx::Sub(const std::string& name) const {
  return {source, field.empty() ? name : field + "." + name};
}

YamlCtx YamlCtx::Index(std::size_t i) const { return {source, field + "[" + std::to_string(i) + "]"}; }

YAML::Node LoadYaml(const std::string& text, const std::string& source) {
  try {
    return YAML::Load(text);
  } catch (const YAML::Exception& e) {
    throw UserError(source + ":" + std::to_string(e.mark.line + 1) + ": not valid YAML: " + OneLine(e.msg));
  }
}

bool Has(const YAML::Node& map, const char* key) {
  const YAML::Node n = map[key];
  return n.IsDefined() && !n.IsNull();
}

YAML::Node Require(const YAML::Node& map, const char* key, const YamlCtx& ctx) {
  if (!Has(map, key)) ctx.Fail(map, std::string("missing field '") + key + "'");
  return map[key];
}

double Number(const YAML::Node& n, const YamlCtx& ctx) {
  if (!n.IsScalar()) ctx.Fail(n, "expected a number");
  double v = 0;
  if (!YAML::convert<double>::decode(n, v)) ctx.Fail(n, "expected a number, got '" + n.Scalar() + "'");
  if (!std::isfinite(v)) ctx.Fail(n, "value is not finite");
  return v;
}

int Integer(const YAML::Node& n, const YamlCtx& ctx) {
  int v = 0;
  if (!n.IsScalar() || !YAML::convert<int>::decode(n, v)) ctx.Fail(n, "expected an integer");
  return v;
}

bool Boolean(const YAML::Node& n, const YamlCtx& ctx) {
  bool v = false;
  if (!n.IsScalar() || !YAML::convert<bool>::decode(n, v)) ctx.Fail(n, "expected true or false");
  return v;
}

std::string String(const YAML::Node& n, const YamlCtx& ctx) {
  if (!n.IsScalar()) ctx.Fail(n, "expected a string");
  return n.Scalar();
}

double NumberOr(const YAML::Node& map, const char* key, double fallback, const YamlCtx& ctx) {
  return Has(map, key) ? Number(map[key], ctx.Sub(key)) : fallback;
}

int IntegerOr(const YAML::Node& map, const char* key, int fallback, const YamlCtx& ctx) {
  return Has(map, key) ? Integer(map[key], ctx.Sub(key)) : fallback;
}

bool BooleanOr(const YAML::Node& map, const char* key, bool fallback, const YamlCtx& ctx) {
  return Has(map, key) ? Boolean(map[key], ctx.Sub(key)) : fallback;
}

void RejectUnknownKeys(const YAML::Node& map, std::initializer_list<const char*> known, const YamlCtx& ctx) {
  if (!map.IsMap()) ctx.Fail(map, "expected a map");
  for (const auto& kv : map) {
    if (!kv.first.IsScalar()) ctx.Fail(kv.first, "a key must be a name, not a list or a map");
    const std::string key = kv.first.Scalar();
    bool found = false;
    for (const char* k : known) found = found || key == k;
    if (!found) ctx.Fail(kv.first, "unknown field '" + key + "'");
  }
}

}  // namespace mfns::host
