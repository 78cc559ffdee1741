// glTF import: the medium of each material (KHR_materials_ior, _transmission, _volume).
#include "import/gltf_importer.h"

namespace shrefract::bake::gltf_detail {
namespace {

// Reads an optional number from an extension object; absent keeps `value`.
void readNumber(const tinygltf::Value& object, const char* key, double& value, std::string& bad) {
  if (!object.IsObject() || !object.Has(key)) {
    return;
  }
  const tinygltf::Value& v = object.Get(key);
  if (!v.IsNumber() || !std::isfinite(v.GetNumberAsDouble())) {
    bad = key;
    return;
  }
  value = v.GetNumberAsDouble();
}

const tinygltf::Value* findExtension(const tinygltf::Material& material, const char* name) {
  const auto it = material.extensions.find(name);
  return it == material.extensions.end() ? nullptr : &it->second;
}

// KHR_materials_volume's attenuationColor, when present: three finite numbers.
void readAttenuationColor(const tinygltf::Value& ext, MaterialVolume& out) {
  if (!ext.IsObject() || !ext.Has("attenuationColor")) {
    return;
  }
  const tinygltf::Value& c = ext.Get("attenuationColor");
  bool valid = c.IsArray() && c.ArrayLen() == 3;
  for (int k = 0; valid && k < 3; ++k) {
    valid = c.Get(k).IsNumber() && std::isfinite(c.Get(k).GetNumberAsDouble());
    if (valid) {
      out.color[k] = c.Get(k).GetNumberAsDouble();
    }
  }
  if (!valid) {
    out.bad = "attenuationColor";
  }
}

MaterialVolume readMaterialVolume(const tinygltf::Material& material) {
  MaterialVolume out;
  if (const tinygltf::Value* ext = findExtension(material, "KHR_materials_ior")) {
    readNumber(*ext, "ior", out.ior, out.bad);
  }
  if (const tinygltf::Value* ext = findExtension(material, "KHR_materials_transmission")) {
    readNumber(*ext, "transmissionFactor", out.transmission, out.bad);
  }
  if (const tinygltf::Value* ext = findExtension(material, "KHR_materials_volume")) {
    readNumber(*ext, "thicknessFactor", out.thickness, out.bad);
    readNumber(*ext, "attenuationDistance", out.distance, out.bad);
    readAttenuationColor(*ext, out);
  }
  return out;
}

// The medium's absorption and tint from a finite attenuationDistance.
void applyAttenuation(double distance, const glm::dvec3& color, Medium& medium) {
  double sigma = 0.0;
  for (int k = 0; k < 3; ++k) {
    sigma += -std::log(std::max(color[k], kMinAttenuationColor)) / distance;
  }
  // Grey attenuation goes into tau (mean of the channel coefficients); the tint keeps only the
  // hue, brightest channel 1, so that grey is not counted twice and the tint never brightens.
  medium.absorption = static_cast<float>(sigma / 3.0);
  const double brightest = std::max({color.x, color.y, color.z, kMinAttenuationColor});
  medium.color = glm::vec3(glm::max(color, glm::dvec3(kMinAttenuationColor)) / brightest);
}

}  // namespace

Result<void> Importer::checkMaterialVolume(const std::string& what, const MaterialVolume& m) const {
  if (!m.bad.empty()) {
    return fail(ErrorCode::CorruptData, what + " has a malformed " + m.bad);
  }
  if (!(m.ior > 0.0) && !options_.iorOverride) {
    return fail(ErrorCode::InvalidArgument,
                what + " has ior " + std::to_string(m.ior) + ", not a refractive medium");
  }
  if (!(m.distance > 0.0)) {
    return fail(ErrorCode::CorruptData,
                what + " has attenuationDistance " + std::to_string(m.distance) + " (must be > 0)");
  }
  if (glm::any(glm::lessThan(m.color, glm::dvec3(0.0))) ||
      glm::any(glm::greaterThan(m.color, glm::dvec3(1.0)))) {
    return fail(ErrorCode::CorruptData, what + " has an attenuationColor outside [0, 1]");
  }
  if (m.thickness < 0.0 || m.transmission < 0.0) {
    return fail(ErrorCode::CorruptData,
                what + " has a negative thicknessFactor or transmissionFactor");
  }
  return {};
}

Result<Medium> Importer::mediumOf(int materialIndex) {
  Medium medium;
  medium.ior = kDefaultIor;
  if (materialIndex < 0) {
    medium.name = "default";
    warn("primitives without a material are imported as clear glass (ior 1.5)");
    return medium;
  }
  const tinygltf::Material& material = model_.materials[static_cast<size_t>(materialIndex)];
  const std::string what = "material " + std::to_string(materialIndex) + quoted(material.name);
  medium.name = material.name.empty() ? "material" + std::to_string(materialIndex) : material.name;

  const MaterialVolume m = readMaterialVolume(material);
  if (Result<void> valid = checkMaterialVolume(what, m); !valid) {
    return valid.error();
  }
  medium.ior = static_cast<float>(m.ior);
  if (std::isfinite(m.distance)) {
    applyAttenuation(m.distance, m.color, medium);
  }
  if (m.transmission <= 0.0 && m.thickness <= 0.0) {
    warn(what + " is neither transmissive nor a volume; imported as a clear medium of ior " +
         std::to_string(medium.ior) + " anyway");
  } else if (m.thickness <= 0.0) {
    warn(what + " is thin-walled (no KHR_materials_volume thickness); imported as a solid volume");
  }
  return medium;
}

}  // namespace shrefract::bake::gltf_detail
