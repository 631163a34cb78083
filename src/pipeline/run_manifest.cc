#include "mcvo/pipeline/run_manifest.h"

#include <utility>

#include "mcvo/io/json_util.h"
#include "mcvo/util/error.h"
#include "mcvo/util/file.h"

namespace mcvo {
namespace {

using Json = nlohmann::ordered_json;

// The members of `object` whose values are strings.
std::map<std::string, std::string> StringMap(const Json& object) {
  std::map<std::string, std::string> out;
  for (const auto& item : object.items()) {
    if (item.value().is_string()) out[item.key()] = item.value().get<std::string>();
  }
  return out;
}

std::string StringOr(const Json& object, const char* key, std::string fallback = "") {
  if (object.is_object() && object.contains(key) && object[key].is_string())
    return object[key].get<std::string>();
  return fallback;
}

std::optional<double> Number(const Json& object, const char* key) {
  if (!object.is_object() || !object.contains(key) || !object[key].is_number()) return std::nullopt;
  return object[key].get<double>();
}

}  // namespace

Json RunManifest::ToJson() const {
  Json run;
  run["program"] = program;
  run["version"] = version;
  run["build"] = Json{{"executable_sha256", executable_sha256}, {"blas", blas}};
  run["command_line"] = command_line;
  run["config_source"] = config_source;
  run["config"] = config;
  Json d;
  d["root"] = dataset.root;
  d["format"] = dataset.format;
  d["name"] = dataset.name;
  d["frames"] = dataset.frames;
  d["cameras"] = dataset.cameras;
  run["dataset"] = d;
  run["inputs"] = inputs;
  run["outputs_sha256"] = outputs_sha256;
  run["result"] = result;
  if (!colmap.is_null()) run["colmap"] = colmap;
  run["timing"] = timing;
  return run;
}

RunManifest RunManifest::FromJson(const Json& json) {
  RunManifest m;
  m.present.clear();
  if (!json.is_object()) return m;
  auto take = [&](const char* key, Json::value_t type) -> const Json* {
    if (!json.contains(key)) return nullptr;
    const Json& value = json[key];
    const bool ok =
        value.type() == type || (type == Json::value_t::number_integer && value.is_number_integer());
    if (!ok) return nullptr;
    m.present.insert(key);
    return &value;
  };
  using T = Json::value_t;
  for (const auto& [key, field] : {std::pair<const char*, std::string*>{"program", &m.program},
                                   {"version", &m.version},
                                   {"command_line", &m.command_line},
                                   {"config_source", &m.config_source}}) {
    if (const Json* v = take(key, T::string)) *field = v->get<std::string>();
  }
  if (const Json* v = take("build", T::object)) {
    m.executable_sha256 = StringOr(*v, "executable_sha256");
    m.blas = StringOr(*v, "blas");
  }
  if (const Json* v = take("config", T::object)) m.config = *v;
  if (const Json* v = take("dataset", T::object)) {
    m.dataset.root = StringOr(*v, "root");
    m.dataset.format = StringOr(*v, "format");
    m.dataset.name = StringOr(*v, "name");
    if (v->contains("frames") && (*v)["frames"].is_number_integer())
      m.dataset.frames = (*v)["frames"].get<int>();
    if (v->contains("cameras") && (*v)["cameras"].is_array()) {
      for (const Json& c : (*v)["cameras"]) {
        if (c.is_string()) m.dataset.cameras.push_back(c.get<std::string>());
      }
    }
  }
  if (const Json* v = take("inputs", T::object)) m.inputs = StringMap(*v);
  if (const Json* v = take("outputs_sha256", T::object)) m.outputs_sha256 = StringMap(*v);
  if (const Json* v = take("result", T::object)) m.result = *v;
  if (const Json* v = take("colmap", T::object)) m.colmap = *v;
  if (const Json* v = take("timing", T::object)) m.timing = *v;
  return m;
}

RunManifest RunManifest::Read(const std::filesystem::path& path) {
  // io_internal::ParseJson checks it and names the file, line and column of
  // a syntax error; the ordered parse keeps the members' order.
  const std::string text = ReadFileToString(path);
  io_internal::ParseJson(text, path.string());
  const Json json = Json::parse(text, nullptr, /*allow_exceptions=*/false, /*ignore_comments=*/true);
  if (json.is_discarded()) MCVO_THROW_INPUT(path.string(), ": JSON parse error");
  if (!json.is_object()) MCVO_THROW_INPUT(path.string(), ": expected a JSON object (run.json of mcvo run)");
  return FromJson(json);
}

RunHeadline RunManifest::Headline() const {
  RunHeadline h;
  const Json& r = result;
  if (auto v = Number(r, "frames")) h.frames = static_cast<int>(*v);
  if (auto v = Number(r, "posed_frames")) h.posed_frames = static_cast<int>(*v);
  if (auto v = Number(r, "segments")) h.segments = static_cast<int>(*v);
  if (r.is_object() && r.contains("warning") && r["warning"].is_string())
    h.warning = r["warning"].get<std::string>();
  h.scale_arbitrary = StringOr(r, "scale") == "arbitrary";
  if (r.is_object() && r.contains("trajectory_origin_in_rig_m")) {
    const Json& c = r["trajectory_origin_in_rig_m"];
    if (c.is_array() && c.size() == 3 && c[0].is_number() && c[1].is_number() && c[2].is_number()) {
      const Eigen::Vector3d origin(c[0].get<double>(), c[1].get<double>(), c[2].get<double>());
      if (origin.allFinite()) h.trajectory_origin_in_rig_m = origin;
    }
  }
  h.ate_rmse_m = Number(r, "ate_rmse_m");
  h.ate_percent_of_path = Number(r, "ate_percent_of_path");
  h.scale_error_percent = Number(r, "scale_error_percent");
  h.rpe_translation_percent = Number(r, "rpe_translation_percent");
  h.rpe_rotation_deg_per_100m = Number(r, "rpe_rotation_deg_per_100m");
  h.frames_per_second = Number(timing, "frames_per_second");
  return h;
}

}  // namespace mcvo
