// The object's shadow on the real table (docs/render.md, "Table, phantom geometry and shadows"):
// a ratio per pixel where the camera ray meets the table plane,
//
//   ratio = E(with the object) / E(without) = (sum_i E_i V_i + E_a - O_a) / (sum_i E_i + E_a)   (RGB)
//
// with E_i the irradiance that dominant light i gives the table (radiance * solid angle * cos of
// its elevation), V_i the visible fraction of its disc from the table point, E_a the ambient
// part's irradiance on the table and O_a what the object takes of it. The background (camera
// image or environment) is multiplied by the ratio.
//
// The object is seen by the shadow as a set of spheres (the unit sphere itself for the sphere
// model), tested analytically against each light's cone: V_i is 1 minus the part of the light's
// disc that the sphere's disc covers (the overlap of two discs, the sphere's edge curved as a
// circle of angular radius a on the unit sphere, i.e. tan(a) in the light's tangent plane), so
// the penumbra's width follows the light's angular size. O_a is the table's irradiance from the
// ambient part within the sphere's cap, looked up in maps of that irradiance per steradian for
// caps of a few radii (interpolated in the radius, times the cap's solid angle): an uneven sky is
// taken where the sphere hides it, with each direction's own cosine, up to contact where the
// sphere fills the sky. Several spheres: the V_i multiply, and each sphere takes its share of the
// ambient irradiance still left (as if they hid independent parts of the sky).
// Why not shadow maps: no draw per light, no bias or resolution, a penumbra from the overlap of
// two discs, and a few dozen flops per light and sphere at the table's pixels; the price is that
// a mesh is approximated by spheres.
#pragma once

#include <memory>
#include <optional>
#include <vector>

#include <glm/glm.hpp>

#include "appliance/core/hdr_image.hpp"
#include "appliance/gl/gl_objects.hpp"
#include "appliance/gl/gl_program.hpp"
#include "appliance/gl/gl_targets.hpp"
#include "appliance/render/dominant_lights.hpp"
#include "appliance/render/mesh.hpp"

namespace glint::render {

inline constexpr int kMaxShadowLights = 4;   // uniform arrays in shaders/render_shadow.frag
inline constexpr int kMaxOccluders = 64;
inline constexpr int kMaxCellsAlongSide = 4;  // occluder_spheres' grid: each sphere costs every table pixel near it
// The table's irradiance from the ambient part within caps of these angular radii (degrees) around
// each direction, per steradian of cap; the shader interpolates between them at an occluder's
// angular radius. Level 0 is the map itself times the cosine to the table's normal.
inline constexpr int kCapLevels = 7;
inline constexpr double kCapRadiiDeg[kCapLevels] = {0, 4, 8, 16, 32, 64, 90};
// Regions wider than this are left in the ambient part: the cap averages take their shape into
// account, a disc would not (a sunlit wall or a patch of bright sky is no disc).
inline constexpr double kMaxShadowLightRadiusDeg = 8.0;

struct ShadowBake;  // shadow_bake.hpp

struct OccluderSphere {
    glm::dvec3 centre{0.0};
    double radius = 1.0;
};

// The spheres the shadow sees for a mesh (in the mesh's frame, which the renderer uses as the
// world frame). A mesh whose vertices and triangle centroids all lie within 1 % of one sphere
// around its bounding box's centre is that sphere. Anything else is voxelised: a grid of up to
// kMaxCellsAlongSide cells along the longest side of its bounding box, a cell is inside when rays
// from its centre along (nearly) +X, +Y and +Z cross the surface an odd number of times (two of
// three), and each inside cell becomes its circumscribed sphere (radius sqrt(3)/2 times the
// cell's side: no light leaks between the spheres, at the price of a shadow too large by the
// overhang); the grid shrinks until at most kMaxOccluders cells are inside. Parts thinner than a
// cell cast no shadow.
std::vector<OccluderSphere> occluder_spheres(const Mesh& mesh);

// The lowest y of the mesh: the default table height (the object stands on the table).
double model_bottom(const Mesh& mesh);

// What the table's shadow needs from the environment: the dominant lights above the table's horizon
// and no wider than kMaxShadowLightRadiusDeg, each light's irradiance on the table (normal +Y,
// from its own texels), the ambient part's irradiance on it, and the cap maps (64x32): for each
// level, around each texel centre o, the sum of L max(0, y) dOmega over the texels of the part
// (averaged down to 128x64) within kCapRadiiDeg of o, divided by their solid angle.
struct ShadowLighting {
    std::vector<DominantLight> lights;  // at most kMaxShadowLights; direction: as the table sees it
    std::vector<glm::dvec3> light_irradiance;
    glm::dvec3 ambient_irradiance{0.0};
    std::vector<HdrImage> ambient_caps;  // kCapLevels maps, 64x32: table irradiance per steradian of cap
};
ShadowLighting shadow_lighting(const HdrImage& environment, DominantLightOptions options = {});

// One cap level: for each texel centre o of a kCapW x kCapH map, the table's irradiance from the
// cap of angular radius `radius` (radians) around o, per steradian of cap,
//   sum_{k: o . w_k >= cos radius} L_k max(0, w_k . y) dOmega_k  /  sum_{same k} dOmega_k,
// over the texels k of `map` (any size); radius 0 gives L(o) max(0, o . y) (block means), and a
// cap holding no texel centre the nearest texel's L max(0, w . y).
inline constexpr int kCapW = 64, kCapH = 32;
HdrImage ambient_cap_density(const HdrImage& map, double radius);

// The shadow's GL side: its uniforms for any program that includes shaders/render_shadow.glsl
// (the composite and the metering background evaluate the ratio where they show it), and the
// ratio of each pixel into one RGBA32F target for the AOV: RGB = the ratio, A = 1 where the
// camera ray meets the table plane, (1, 1, 1, 0) elsewhere. GL, on the context's thread.
class TableShadowPass {
public:
    TableShadowPass(int width, int height, const ShadowLighting& lighting, std::vector<OccluderSphere> occluders,
                    double table_height);
    // Sets render_shadow.glsl's uniforms on `program` (in use), its cap maps on texture unit
    // caps_unit; the camera ray uniforms are the caller's.
    void set_uniforms(const gl::GlProgram& program, int caps_unit, const glm::vec3& eye) const;
    // u_world_from_camera, u_tan_half_fov as in shaders/render_composite.frag.
    void draw(const glm::mat3& world_from_camera, const glm::vec2& tan_half_fov, const glm::vec3& eye) const;
    // The ratio, rows top first, 4 floats a pixel.
    std::vector<float> read() const;
    double table_height() const { return table_height_; }
    // The shadow baked against the real mesh (shadow_bake.hpp): used inside its grid, on texture
    // units kBakeUnit and kBakeUnit + 1 of every program that shows the shadow.
    void set_bake(const ShadowBake& bake);
    bool baked() const { return bake_res_ > 0; }
    // The bake holds the whole shadow (ShadowBake::open_beyond): the frames may compile the
    // spheres' model out (render_shadow.glsl's SHADOW_BAKE_ONLY); the AOV keeps it.
    bool bake_holds_all() const { return bake_res_ > 0 && bake_open_beyond_; }
    static constexpr int kBakeUnit = 6;
    void set_table_height(double height) { table_height_ = height; }

private:
    int width_, height_;
    double table_height_;
    ShadowLighting lighting_;
    std::vector<OccluderSphere> occluders_;
    OccluderSphere bound_;  // around all occluders: render_shadow.glsl tests it first
    // The ratio's own pass, for the AOV only (frames evaluate the ratio in the composite): made at
    // its first draw, so that a kiosk changing rooms per visitor compiles nothing on the frame.
    mutable std::optional<gl::GlProgram> program_;
    gl::GlTexture caps_;  // the cap maps stacked
    gl::GlTexture bake_lights_, bake_ambient_;
    int bake_res_ = 0;
    bool bake_open_beyond_ = false;
    glm::vec2 bake_origin_{0.0f};
    float bake_spacing_ = 0;
    gl::GlVertexArray empty_vao_;
    mutable std::optional<gl::RenderTargets> target_;
};

}  // namespace glint::render
