#include "importers/extensions.h"

namespace radbake {

const std::vector<KnownExtension>& knownExtensions() {
  using U = ExtensionUse;
  // The notes finish the sentence "radbake ..." in README's table and follow "NAME is
  // approximated: " in warnings. radbake's surfaces are Lambertian with ρ = base color × (1 −
  // metallic): the glTF BRDF's specular lobe and its Fresnel weighting of the diffuse lobe are left
  // out for every material, so an extension that only shapes the specular lobe changes nothing here.
  static const std::vector<KnownExtension> table = {
      {"KHR_lights_punctual", U::kBaked, "point, spot and directional lights light the scene as shadowed direct light (cd, lx)"},
      {"KHR_materials_emissive_strength", U::kBaked, "emitted radiance is emissiveFactor × emissiveStrength"},
      {"KHR_texture_transform", U::kBaked, "base color and emissive textures are sampled where the transform puts them"},
      {"KHR_mesh_quantization", U::kBaked, "integer and normalized vertex attributes are read as the extension maps them"},
      {"KHR_draco_mesh_compression", U::kBaked, "decoded; the output holds the geometry uncompressed, without the extension"},
      {"EXT_meshopt_compression", U::kBaked, "decoded; the output holds the buffer views uncompressed, without the extension"},
      {"KHR_materials_unlit", U::kKept, "an unlit input material reflects as a diffuse surface of its base color (the extension's fallback); every baked material is written unlit"},
      {"KHR_materials_anisotropy", U::kKept, "shapes the specular lobe only"},
      {"KHR_materials_dispersion", U::kKept, "acts on transmitted light only, which radbake leaves out (see KHR_materials_transmission)"},
      {"KHR_xmp_json_ld", U::kKept, "metadata"},
      {"MOZ_lightmap", U::kKept, "kept; replaced by the baked lightmap with --lightmap"},
      {"KHR_texture_basisu", U::kFallback, "KTX2 images are not decoded; the texture's PNG/JPEG source is baked"},
      {"EXT_texture_webp", U::kFallback, "WebP images are not decoded; the texture's PNG/JPEG source is baked"},
      {"EXT_texture_avif", U::kFallback, "AVIF images are not decoded; the texture's PNG/JPEG source is baked"},
      {"KHR_meshopt_compression", U::kFallback, "(draft) not decoded: its COLOR filter postdates Debian's meshoptimizer 0.18; the uncompressed fallback buffer is read and the extension dropped"},
      {"KHR_materials_clearcoat", U::kApproximated, "the coat is left out; the base layer's diffuse color is baked"},
      {"KHR_materials_sheen", U::kApproximated, "the sheen layer is left out; the base layer's diffuse color is baked"},
      {"KHR_materials_specular", U::kApproximated, "its Fresnel weighting of the diffuse lobe is left out"},
      {"KHR_materials_ior", U::kApproximated, "its Fresnel weighting of the diffuse lobe is left out"},
      {"KHR_materials_iridescence", U::kApproximated, "its Fresnel weighting of the diffuse lobe is left out"},
      {"KHR_materials_transmission", U::kApproximated, "surfaces are baked opaque: light passing through them is left out"},
      {"KHR_materials_diffuse_transmission", U::kApproximated, "surfaces are baked opaque: light passing through them is left out"},
      {"KHR_materials_volume", U::kApproximated, "surfaces are baked opaque: light passing through them is left out"},
      {"KHR_materials_variants", U::kApproximated, "the default materials are baked; the other variants are kept but not baked"},
      {"KHR_materials_pbrSpecularGlossiness", U::kApproximated, "(archived) the core metallic-roughness material is baked, not the diffuse color of this one"},
      {"EXT_mesh_gpu_instancing", U::kApproximated, "the instances are left out of the bake (they neither cast nor receive light); each instanced node's mesh is baked once, at the node"},
      {"MSFT_lod", U::kApproximated, "the finest level (the node's own mesh) is baked; the coarser levels are kept but not baked"},
      {"EXT_lights_image_based", U::kApproximated, "the environment light is left out (--sky gives a uniform sky)"},
      {"KHR_animation_pointer", U::kRefused, "its animation channels have no target node, which tinygltf 2.7 cannot read"},
  };
  return table;
}

const KnownExtension* findExtension(const std::string& name) {
  for (const KnownExtension& e : knownExtensions())
    if (e.name == name) return &e;
  return nullptr;
}

bool acceptedWhenRequired(const std::string& name) {
  const KnownExtension* e = findExtension(name);
  return e && (e->use == ExtensionUse::kBaked || e->use == ExtensionUse::kKept);
}

}  // namespace radbake
