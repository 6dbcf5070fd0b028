// The renderer of `glint render` (docs/render.md): one object, shaded from the maps, into float
// targets (radiance, normal, reflection direction, the frame's HDR radiance), then composited into
// the display's frame over a background with Reinhard's tone mapping.
//
// Frames (docs/conventions.md): world +Y up, -Z forward. The object's bounding sphere is the unit
// sphere at the origin (mesh.hpp, normalise_to_unit_sphere); the camera sits on +Z and looks
// towards -Z at the origin, +Y up, with a vertical field of view of 40 degrees.
//
// Everything GL runs on the thread whose context is current (the display's), as gl/ requires.
#pragma once

#include <filesystem>
#include <map>
#include <memory>
#include <optional>
#include <vector>

#include <glm/glm.hpp>

#include "appliance/core/hdr_image.hpp"
#include "appliance/gl/gl_objects.hpp"
#include "appliance/gl/gl_program.hpp"
#include "appliance/gl/gl_targets.hpp"  // gl::TextureUpload
#include "appliance/gl/png_writer.hpp"  // gl::RgbImage (the struct only)
#include "appliance/render/camera_response.hpp"
#include "appliance/render/maps.hpp"
#include "appliance/render/material.hpp"
#include "appliance/render/mesh.hpp"
#include "appliance/render/phantom.hpp"
#include "appliance/render/shadow.hpp"
#include "appliance/render/shadow_bake.hpp"

namespace glint::render {

struct Camera {
    glm::dvec3 eye{0.0, 0.0, 3.5};  // the unit sphere spans 79 % of the frame's height
    glm::dvec3 target{0.0};
    glm::dvec3 up{0.0, 1.0, 0.0};
    double fov_y_deg = 40.0;         // vertical; horizontal follows the frame's aspect
    double near = 0.1, far = 100.0;  // world units (the object's radius is 1)
};

enum class Background { Environment, Black, Image };

// Reinhard's global operator (Reinhard, Stark, Shirley, Ferwerda 2002, eq. 1, 2 and 4):
//   L_avg = exp(mean(log(delta + L))) over the metered pixels,  L_s = key / L_avg * L,
//   L_d = L_s (1 + L_s / L_white^2) / (1 + L_s),  with L_white the largest L_s metered (so the
// brightest pixel maps to 1) and L the Rec. 709 luminance.
struct ToneMap {
    double key = 0.18;
    double delta = 1e-4;
    double log_average = 1.0;  // L_avg
    double white = 1.0;        // L_white, in scaled luminance L_s
    long long pixels = 0;      // pixels metered
    double scale() const { return key / log_average; }
};

// Meters RGBA pixels (alpha > 0 counts: the object, and the environment when it is the
// background). No pixel counted gives L_avg = key (scale 1) and L_white = 1.
ToneMap meter_reinhard(const std::vector<float>& rgba, double key = 0.18, double delta = 1e-4);

// The arbitrary output variables of the last draw_scene, rows top first, 4 floats a pixel.
struct Aovs {
    int width = 0, height = 0;
    std::vector<float> radiance;  // RGB before any tone mapping, A = 1 on the object, all 0 off it
    std::vector<float> normal;    // unit world-space normal (A = 1 on the object, -1 where a proxy is nearest)
    std::vector<float> reflect;   // unit world-space reflection direction (A = 1 on the object)
    std::vector<float> shadow;    // the table's shadow ratio (RGB, 1 = unshadowed; A = 1 on the table); empty when off
};

// Writes radiance.exr (R, G, B, A), normal.exr and reflect.exr (R, G, B = x, y, z), and shadow.exr
// (R, G, B = the ratio) when the shadow is on, into `dir`
// (created if missing), each atomically. normal and reflect hold signed values: core's load_exr
// clamps negatives (it reads radiance), so read them with OpenEXR directly.
void save_aovs(const std::filesystem::path& dir, const Aovs& aovs);

// RAII for the depth buffer (gl_objects.hpp has no renderbuffer).
struct RenderbufferTraits {
    static GLuint create() { GLuint id = 0; glGenRenderbuffers(1, &id); return id; }
    static void destroy(GLuint id) { glDeleteRenderbuffers(1, &id); }
};

// The float format of the frames' targets (docs/render.md, "Frame targets"). Auto: RGBA32F where
// the driver can multisample it at the requested count (llvmpipe can), else RGBA16F. Half:
// RGBA16F (half the bytes a sample: the plan for a tile-based GPU such as the Pi's); the radiance
// is then capped at 65504, half's largest, and held to 1e-3 relative. AOVs are always RGBA32F.
enum class FrameTargets { Auto, Float, Half };

class Renderer {
public:
    // The maps must hold what the material needs (needed_maps). width, height: the frame's.
    // msaa: samples per pixel of the frame's targets, 1 (none) or 4 (docs/render.md, "MSAA").
    Renderer(const Mesh& mesh, const Material& material, const ShadingMaps& maps, int width, int height,
             const Camera& camera = {}, int msaa = 1, FrameTargets targets = FrameTargets::Auto);
    // Several materials: one per part of the mesh (Mesh::parts, part_materials), or one for a mesh
    // without parts. The triangles are grouped by distinct material, one draw each.
    Renderer(const Mesh& mesh, const std::vector<Material>& part_materials, const ShadingMaps& maps, int width,
             int height, const Camera& camera = {}, int msaa = 1, FrameTargets targets = FrameTargets::Auto);
    Renderer(const Renderer&) = delete;
    Renderer& operator=(const Renderer&) = delete;

    void set_background_environment(const HdrImage& environment);
    void set_background_image(const gl::RgbImage& image);
    void set_background_black();
    // Off: ao = 1 (--no-ao). On: the mesh's baked ao (Mesh::ao), or 1 when it has none.
    void set_ambient_occlusion(bool on) { ao_ = on; }

    // Draws the object into the float targets (radiance, normal, reflection direction).
    void draw_scene();
    // Draws the frame's HDR radiance (the environment background and the object) into a fourth
    // target, reads it back and meters it; keeps the result. Once per still scene: frames do not
    // write that target (the composite looks the environment up itself).
    const ToneMap& meter(double key = 0.18);
    void set_tone_map(const ToneMap& tone) { tone_ = tone; }
    // Into the camera's image space instead of Reinhard and sRGB (docs/render.md, "Camera
    // response"): the object's (and the environment's) radiance x exposure x gain x sensitivity
    // through the response curve; an image background is decoded with the inverse response (its
    // codes are the camera's) wherever it is mixed or shadowed.
    void set_camera_response(const CameraResponse& response, const CameraExposure& exposure);
    // Matching the camera on virtual pixels (docs/render.md, "Matching the camera"): the sensor's
    // noise (needs set_camera_response with a calibration that has "noise"; a new pattern for
    // each `frame`) and the object's motion blur (its motion on screen during the exposure, in
    // pixels, x right and y up; at most 256). Off by default. Throws InputError naming what is
    // missing.
    struct CameraMatch {
        bool noise = false;
        std::uint32_t frame = 0;
        glm::dvec2 blur_px{0.0, 0.0};
    };
    void set_camera_match(const CameraMatch& match);
    const ToneMap& tone_map() const { return tone_; }
    // Draws the frame into the bound framebuffer, whose viewport must be width x height.
    void composite() const;
    // The AOVs of the scene, exact at every pixel: the scene is drawn once more with one sample a
    // pixel and the reflection target on (frames do not write it; with MSAA a resolved normal would
    // not be unit, a resolved radiance not the shading of any one direction), which overwrites the
    // frame's targets.
    Aovs read_aovs();
    // The radiance target the composite reads, after draw_scene: with MSAA resolved, so alpha is
    // the object's coverage of the pixel (fractional on its silhouette), RGB premultiplied by it.
    std::vector<float> read_frame_radiance() const;
    int msaa() const { return msaa_; }
    // "RGBA32F" or "RGBA16F": the frames' targets.
    const char* frame_format() const { return half_ ? "RGBA16F" : "RGBA32F"; }

    // The real table and things on it (docs/render.md, "Table, phantom geometry and shadows").
    // The table plane y = height and proxy meshes (world coordinates, not normalised) go into the
    // depth buffer before the object, so they hide it where they are in front.
    void set_table(double height);
    void add_proxy(const Mesh& proxy);
    // The object's shadow on the table darkens the background there (camera image or environment).
    // Needs set_table first. Off by default.
    void enable_shadows(const ShadowLighting& lighting, std::vector<OccluderSphere> occluders);
    bool shadows() const { return shadow_ != nullptr; }
    // The shadow baked against the mesh itself (shadow_bake.hpp), used inside its grid. Needs
    // enable_shadows first.
    void set_shadow_bake(const ShadowBake& bake);

    int width() const { return width_; }
    int height() const { return height_; }
    const Camera& camera() const { return camera_; }
    // The view from the next draw on (the kiosk moves it every frame with the tracked pose).
    void set_camera(const Camera& camera) { camera_ = camera; }
    std::size_t draws() const { return draws_.size(); }  // one per distinct material
    // Shades with other maps of the same lobes from the next draw on (live_maps.hpp: the final
    // maps after the coarse ones). Throws RuntimeError when one the materials need is missing.
    void replace_maps(const ShadingMaps& maps);
    // The same without a copy: the renderer keeps `maps` (the kiosk's final maps are 10 MB, and
    // two copies of them cost the frame they arrived in 33 ms).
    void replace_maps(std::shared_ptr<const ShadingMaps> maps);
    // One material for every part from the next draw on (the kiosk's button cycles the object's
    // materials without a renderer, and its shaders, per material). The maps last given (at
    // construction or by replace_maps) must hold its lobes; its maps are uploaded now.
    void set_uniform_material(const Material& material);
    // replace_maps uploads the maps the draws use at once and the others (for the materials the
    // button may switch to) in bands of about `max_bytes` per call of this, from the frames with
    // time to spare (gl::TextureUpload). Returns false when none is left. set_uniform_material
    // uploads what it needs if it is still waiting.
    static constexpr std::size_t kPendingBandBytes = gl::kUploadBandBytes;
    bool upload_pending_map(std::size_t max_bytes = kPendingBandBytes);

private:
    std::vector<float> read_target(int k, bool aov = false) const;  // rows top first
    // aov: into the AOVs' RGBA32F targets (half-float frames), uncapped.
    void draw(bool with_hdr, bool multisampled, bool with_reflect = false, bool aov = false);
    void resolve(bool with_hdr) const;
    void create_multisampled_targets();  // the multisampled targets into the textures the composite reads
    void set_camera_ray_uniforms(const gl::GlProgram& program) const;  // u_size, u_tan_half_fov, u_world_from_camera
    void draw_shadow() const;                                          // the ratio's target (the AOV), when shadows are on
    void bind_shadow(const gl::GlProgram& program, int unit) const;    // u_has_shadow and render_shadow.glsl's uniforms

    int width_, height_;
    Camera camera_;
    // One draw per distinct material: its index range (grouped at upload) and reflection map.
    struct Draw {
        Material material;
        std::size_t first_index = 0, index_count = 0;
        int reflection = -1;  // into reflection_textures_ (and maps_.reflections)
    };
    std::vector<Draw> draws_;
    std::shared_ptr<const ShadingMaps> maps_;  // the last maps given, for set_uniform_material
    std::size_t index_total_ = 0;  // indices of every part
    std::vector<gl::GlTexture> reflection_textures_;  // one per maps_.reflections, in order
    void upload_maps(bool later);     // textures for maps_ (upload_pending_map)
    void upload_map_now(int k);       // a pending map (k: a reflection, -1 the irradiance)
    const HdrImage& map_image(int k) const;                // k as upload_map_now's
    void finish_upload(int k, gl::GlTexture texture);     // k's texture in use, no longer pending
    std::vector<int> pending_maps_;   // maps given but not uploaded yet (upload_pending_map)
    std::optional<gl::TextureUpload> uploading_;  // the first pending map's, under way
    Background background_ = Background::Black;
    bool ao_ = true;
    ToneMap tone_;
    gl::GlProgram scene_program_, background_program_;
    // The composite's variants (background, camera curve, shadow: render_composite.frag's defines),
    // each compiled at its first use; composite_program() picks the one the state asks for.
    mutable std::map<int, gl::GlProgram> composite_programs_;
    const gl::GlProgram& composite_program() const;
    gl::GlVertexArray vao_, empty_vao_;
    gl::GlBuffer vertices_, indices_, ao_values_;
    bool has_ao_ = false;  // the mesh came with baked ao (attribute 2)
    gl::GlTexture irradiance_, environment_, image_;
    int image_width_ = 0, image_height_ = 0;  // image_'s size
    gl::GlTexture targets_[4];
    gl::GlName<RenderbufferTraits> depth_;
    gl::GlFramebuffer framebuffer_;
    // Half-float frames: the AOVs' own RGBA32F targets and depth, made at the first read_aovs.
    bool half_ = false;
    gl::GlTexture aov_targets_[4];
    gl::GlName<RenderbufferTraits> aov_depth_;
    gl::GlFramebuffer aov_framebuffer_;
    // Float targets of this frame's size (RGBA16F or RGBA32F) with depth into `framebuffer`.
    void make_targets(bool half, gl::GlTexture (&textures)[4], gl::GlName<RenderbufferTraits>& depth,
                      gl::GlFramebuffer& framebuffer);
    // MSAA: multisampled float renderbuffers (same four targets) and depth, resolved by blit.
    int msaa_ = 1;
    gl::GlName<RenderbufferTraits> ms_colour_[4], ms_depth_;
    gl::GlFramebuffer ms_framebuffer_;
    std::optional<CameraResponse> response_curve_;
    CameraExposure exposure_;
    CameraMatch match_;
    gl::GlTexture response_;  // 256x1 R32F: inverse[z]
    std::unique_ptr<PhantomGeometry> phantoms_;
    std::unique_ptr<TableShadowPass> shadow_;
};

}  // namespace glint::render
