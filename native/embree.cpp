// Embree scenes built and cast from here (texbake/sampling/rays.py), through the Embree 4
// library that embreex ships (opened by its path with dlopen; embreex's own binding copies a
// scene element by element through Python, about 1.3 s a million faces). The scene, its
// flags and its rays are set up as embreex sets them (robust scene, float3 vertices with a
// stride of 16 bytes, uint3 faces, one ray at a time with tnear 0), so the same rays find the
// same faces. Only the part of Embree's API used here is declared, as include/embree4 has it.
#include <dlfcn.h>
#include <unistd.h>
#include <nanobind/stl/string.h>

#include <cmath>
#include <cstdint>
#include <stdexcept>
#include <string>

#include "arrays.hpp"
#include "parallel.hpp"

namespace texbake {
namespace {

// -- the declarations (Embree 4: rtcore_common.h, rtcore_ray.h, rtcore_scene.h, ...) --
using RTCDevice = void*;
using RTCScene = void*;
using RTCGeometry = void*;
constexpr unsigned INVALID_ID = 0xFFFFFFFFu;
constexpr int GEOMETRY_TYPE_TRIANGLE = 0, BUFFER_TYPE_INDEX = 0, BUFFER_TYPE_VERTEX = 1;
constexpr int FORMAT_UINT3 = 0x5003, FORMAT_FLOAT3 = 0x9003, SCENE_FLAG_ROBUST = 1 << 2, PROPERTY_VERSION_MAJOR = 1;

struct alignas(16) Ray {
  float org_x, org_y, org_z, tnear, dir_x, dir_y, dir_z, time, tfar;
  unsigned mask, id, flags;
};
struct alignas(16) Hit {
  float Ng_x, Ng_y, Ng_z, u, v;
  unsigned primID, geomID, instID[1], instPrimID[1];
  unsigned spare[4];  // room for a build with more instance levels: Embree writes no further than its own struct
};
struct RayHit {
  Ray ray;
  Hit hit;
};
// packets of 8 (rtcore_ray.h's RTCRay8 / RTCRayHit8, structure of arrays)
struct alignas(32) Ray8 {
  float org_x[8], org_y[8], org_z[8], tnear[8], dir_x[8], dir_y[8], dir_z[8], time[8], tfar[8];
  unsigned mask[8], id[8], flags[8];
};
struct alignas(32) RayHit8 {
  Ray8 ray;
  float Ng_x[8], Ng_y[8], Ng_z[8], u[8], v[8];
  unsigned primID[8], geomID[8], instID[8][8], instPrimID[8][8];  // room for up to 8 instance levels
};

struct Api {
  RTCDevice (*rtcNewDevice)(const char*);
  int (*rtcGetDeviceError)(RTCDevice);
  ptrdiff_t (*rtcGetDeviceProperty)(RTCDevice, int);
  RTCScene (*rtcNewScene)(RTCDevice);
  void (*rtcSetSceneFlags)(RTCScene, int);
  void (*rtcCommitScene)(RTCScene);
  void (*rtcReleaseScene)(RTCScene);
  RTCGeometry (*rtcNewGeometry)(RTCDevice, int);
  void* (*rtcSetNewGeometryBuffer)(RTCGeometry, int, unsigned, int, size_t, size_t);
  void (*rtcCommitGeometry)(RTCGeometry);
  unsigned (*rtcAttachGeometry)(RTCScene, RTCGeometry);
  void (*rtcReleaseGeometry)(RTCGeometry);
  void (*rtcIntersect1)(RTCScene, RayHit*, void*);
  void (*rtcIntersect8)(const int*, RTCScene, RayHit8*, void*);
  void (*rtcOccluded8)(const int*, RTCScene, Ray8*, void*);
  RTCDevice device = nullptr;
  pid_t pid = 0;  // the process the device was made in
};

Api api;

template <class F>
void find(void* library, const char* name, F& out) {
  out = reinterpret_cast<F>(dlsym(library, name));
  if (!out) throw std::runtime_error(std::string("embree: ") + name + " not found");
}

// Open Embree at path (once a process) and make the device every scene is made on
void open_embree(const std::string& path) {
  if (api.device) return;
  void* library = dlopen(path.c_str(), RTLD_NOW | RTLD_LOCAL);
  if (!library) throw std::runtime_error(std::string("embree: cannot open ") + path + ": " + dlerror());
  Api found;
  find(library, "rtcNewDevice", found.rtcNewDevice);
  find(library, "rtcGetDeviceError", found.rtcGetDeviceError);
  find(library, "rtcGetDeviceProperty", found.rtcGetDeviceProperty);
  find(library, "rtcNewScene", found.rtcNewScene);
  find(library, "rtcSetSceneFlags", found.rtcSetSceneFlags);
  find(library, "rtcCommitScene", found.rtcCommitScene);
  find(library, "rtcReleaseScene", found.rtcReleaseScene);
  find(library, "rtcNewGeometry", found.rtcNewGeometry);
  find(library, "rtcSetNewGeometryBuffer", found.rtcSetNewGeometryBuffer);
  find(library, "rtcCommitGeometry", found.rtcCommitGeometry);
  find(library, "rtcAttachGeometry", found.rtcAttachGeometry);
  find(library, "rtcReleaseGeometry", found.rtcReleaseGeometry);
  find(library, "rtcIntersect1", found.rtcIntersect1);
  find(library, "rtcIntersect8", found.rtcIntersect8);
  find(library, "rtcOccluded8", found.rtcOccluded8);
  RTCDevice device = found.rtcNewDevice(nullptr);  // embreex's configuration: the defaults
  if (!device) throw std::runtime_error("embree: no device");
  const ptrdiff_t major = found.rtcGetDeviceProperty(device, PROPERTY_VERSION_MAJOR);
  if (major != 4) throw std::runtime_error("embree: version " + std::to_string(major) + ", not 4");
  found.device = device;
  found.pid = getpid();
  api = found;
}

// the device of this process: a child forked after a scene was made gets its own (as embreex
// makes one a scene), the parent's threads being gone
RTCDevice device() {
  if (api.pid != getpid()) {
    api.device = api.rtcNewDevice(nullptr);
    api.pid = getpid();
    if (!api.device) throw std::runtime_error("embree: no device");
  }
  return api.device;
}

class Scene {
 public:
  Scene(In<float, shape<-1, 3>> vertices, In<int64_t, shape<-1, 3>> faces) {
    if (!api.device) throw std::runtime_error("embree: not opened");
    const int64_t n = vertices.shape(0), m = faces.shape(0);
    for (int64_t i = 0; i < 3 * m; ++i) {
      if (faces.data()[i] < 0 || faces.data()[i] >= n) throw nb::index_error("embree: a face index outside the vertices");
    }
    RTCDevice dev = device();
    nb::gil_scoped_release unlocked;
    scene_ = api.rtcNewScene(dev);
    api.rtcSetSceneFlags(scene_, SCENE_FLAG_ROBUST);
    RTCGeometry geometry = api.rtcNewGeometry(dev, GEOMETRY_TYPE_TRIANGLE);
    auto* v = static_cast<float*>(api.rtcSetNewGeometryBuffer(geometry, BUFFER_TYPE_VERTEX, 0, FORMAT_FLOAT3, 16, size_t(n)));
    auto* t = static_cast<unsigned*>(api.rtcSetNewGeometryBuffer(geometry, BUFFER_TYPE_INDEX, 0, FORMAT_UINT3, 12, size_t(m)));
    if (!v || !t) throw std::runtime_error("embree: no memory for the scene's buffers");
    parallel_for(n, [&](int64_t begin, int64_t end) {
      for (int64_t i = begin; i < end; ++i) {
        for (int k = 0; k < 3; ++k) v[4 * i + k] = vertices.data()[3 * i + k];
        v[4 * i + 3] = 0.0f;
      }
    });
    parallel_for(3 * m, [&](int64_t begin, int64_t end) {
      for (int64_t i = begin; i < end; ++i) t[i] = unsigned(faces.data()[i]);
    });
    api.rtcCommitGeometry(geometry);
    api.rtcAttachGeometry(scene_, geometry);
    api.rtcReleaseGeometry(geometry);
    api.rtcCommitScene(scene_);  // the BVH, on Embree's threads
    if (const int error = api.rtcGetDeviceError(dev)) throw std::runtime_error("embree: error " + std::to_string(error) + " building the scene");
  }
  ~Scene() {
    if (scene_) api.rtcReleaseScene(scene_);
  }
  Scene(const Scene&) = delete;
  Scene& operator=(const Scene&) = delete;

  // face (n,) int32 of each ray's first hit (-1: none), tfar (n,) float32 its distance (in:
  // the bound; unchanged where nothing is hit)
  void cast(In<float, shape<-1, 3>> origins, In<float, shape<-1, 3>> directions, Out<int32_t, nb::ndim<1>> face,
            Out<float, nb::ndim<1>> tfar) const {
    const int64_t n = origins.shape(0), step = directions.shape(0) == 1 ? 0 : 1;
    if ((step && int64_t(directions.shape(0)) != n) || int64_t(face.shape(0)) != n || int64_t(tfar.shape(0)) != n)
      throw std::invalid_argument("cast: directions (n, 3) or (1, 3), face and tfar (n,)");
    const float *o = origins.data(), *d = directions.data();
    for (int64_t i = 0; i < n; ++i) {
      RayHit r;
      r.ray = Ray{o[3 * i], o[3 * i + 1], o[3 * i + 2], 0.0f, d[3 * step * i], d[3 * step * i + 1], d[3 * step * i + 2],
                  0.0f, tfar.data()[i], 0xFFFFFFFFu, 0u, 0u};
      r.hit.geomID = r.hit.primID = r.hit.instID[0] = INVALID_ID;
      api.rtcIntersect1(scene_, &r, nullptr);
      face.data()[i] = r.hit.primID == INVALID_ID ? -1 : int32_t(r.hit.primID);
      tfar.data()[i] = r.ray.tfar;
    }
  }

  // cast, over every core, also giving each hit's barycentric (u, v) (n, 2) float32 of the
  // face's corners 1 and 2 (Embree's; 0 where nothing is hit): a high-to-low bake
  // interpolates the source's normals with them, with no second pass over the triangles
  void cast_uv(In<float, shape<-1, 3>> origins, In<float, shape<-1, 3>> directions, Out<int32_t, nb::ndim<1>> face,
               Out<float, nb::ndim<1>> tfar, Out<float, shape<-1, 2>> uv) const {
    const int64_t n = origins.shape(0), step = directions.shape(0) == 1 ? 0 : 1;
    if ((step && int64_t(directions.shape(0)) != n) || int64_t(face.shape(0)) != n || int64_t(tfar.shape(0)) != n ||
        int64_t(uv.shape(0)) != n)
      throw std::invalid_argument("cast_uv: directions (n, 3) or (1, 3), face and tfar (n,), uv (n, 2)");
    const float *o = origins.data(), *d = directions.data();
    float *t = tfar.data(), *w = uv.data();
    int32_t* f = face.data();
    parallel_for(n, [&](int64_t begin, int64_t end) {
      for (int64_t i = begin; i < end; ++i) {
        RayHit r;
        r.ray = Ray{o[3 * i], o[3 * i + 1], o[3 * i + 2], 0.0f, d[3 * step * i], d[3 * step * i + 1], d[3 * step * i + 2],
                    0.0f, t[i], 0xFFFFFFFFu, 0u, 0u};
        r.hit.geomID = r.hit.primID = r.hit.instID[0] = INVALID_ID;
        api.rtcIntersect1(scene_, &r, nullptr);
        const bool hit = r.hit.primID != INVALID_ID;
        f[i] = hit ? int32_t(r.hit.primID) : -1;
        t[i] = r.ray.tfar;
        w[2 * i] = hit ? r.hit.u : 0.0f;
        w[2 * i + 1] = hit ? r.hit.v : 0.0f;
      }
    }, 4096);
  }

  // High to low (texbake/meshmaps/highpoly.py's project, its reference in numpy): from each
  // target point p (n, 3) float64 with unit smooth normal nrm, a ray from the cage point c
  // (cage (n, 3), or (0, 3): none) towards p and on by back, else from p + front nrm along
  // -nrm, front + back long; its first hit on this scene of the source, whose smooth vertex
  // normals are src_normals (k, 3) and faces src_faces (m, 3) (those the scene holds, in its
  // order). Writes hit (n,) uint8, depth (n,) float64 (the hit's signed distance from p along
  // nrm, 0 where none) and normal (n, 3) float64 (the source's interpolated unit normal, 0
  // where none). The scene's map to the unit box (centre, scale) is applied here as
  // rays.py's _origins applies it.
  void project(In<double, shape<-1, 3>> points, In<double, shape<-1, 3>> normals, In<double, shape<-1, 3>> cage,
               double front, double back, In<double, shape<3>> centre, double scale, In<double, shape<-1, 3>> src_normals,
               In<int64_t, shape<-1, 3>> src_faces, Out<uint8_t, nb::ndim<1>> hit, Out<double, nb::ndim<1>> depth,
               Out<double, shape<-1, 3>> normal) const {
    const int64_t n = points.shape(0), m = src_faces.shape(0), k = src_normals.shape(0);
    const bool caged = cage.shape(0) != 0;
    if (int64_t(normals.shape(0)) != n || (caged && int64_t(cage.shape(0)) != n) || int64_t(hit.shape(0)) != n ||
        int64_t(depth.shape(0)) != n || int64_t(normal.shape(0)) != n)
      throw std::invalid_argument("project: points, normals, cage (or (0, 3)), hit, depth and normal of n rows");
    for (int64_t i = 0; i < 3 * m; ++i) {
      if (src_faces.data()[i] < 0 || src_faces.data()[i] >= k) throw nb::index_error("project: a face index outside the normals");
    }
    const double *P = points.data(), *N = normals.data(), *C = cage.data(), *SN = src_normals.data();
    const int64_t* F = src_faces.data();
    const double cx = centre.data()[0], cy = centre.data()[1], cz = centre.data()[2];
    uint8_t* H = hit.data();
    double *D = depth.data(), *O = normal.data();
    parallel_for(n, [&](int64_t begin, int64_t end) {
      for (int64_t i = begin; i < end; ++i) {
        const double* p = P + 3 * i;
        const double* q = N + 3 * i;
        double o[3], d[3], reach;
        if (caged) {
          const double* c = C + 3 * i;
          double t[3] = {p[0] - c[0], p[1] - c[1], p[2] - c[2]};
          const double len = std::sqrt(t[0] * t[0] + t[1] * t[1] + t[2] * t[2]);
          for (int a = 0; a < 3; ++a) {
            o[a] = c[a];
            d[a] = len > 0 ? t[a] / len : -q[a];
          }
          reach = len + back;
        } else {
          for (int a = 0; a < 3; ++a) {
            o[a] = p[a] + front * q[a];
            d[a] = -q[a];
          }
          reach = front + back;
        }
        RayHit r;
        r.ray = Ray{float((o[0] - cx) / scale), float((o[1] - cy) / scale), float((o[2] - cz) / scale), 0.0f,
                    float(d[0]), float(d[1]), float(d[2]), 0.0f, float(reach / scale), 0xFFFFFFFFu, 0u, 0u};
        r.hit.geomID = r.hit.primID = r.hit.instID[0] = INVALID_ID;
        api.rtcIntersect1(scene_, &r, nullptr);
        double* out = O + 3 * i;
        if (r.hit.primID == INVALID_ID) {
          H[i] = 0;
          D[i] = 0.0;
          out[0] = out[1] = out[2] = 0.0;
          continue;
        }
        const double t = double(r.ray.tfar) * scale, u = r.hit.u, v = r.hit.v, w = 1.0 - u - v;
        const int64_t* f = F + 3 * int64_t(r.hit.primID);
        const double *n0 = SN + 3 * f[0], *n1 = SN + 3 * f[1], *n2 = SN + 3 * f[2];
        double s[3], len2 = 0.0, along = 0.0;
        for (int a = 0; a < 3; ++a) {
          s[a] = w * n0[a] + u * n1[a] + v * n2[a];
          len2 += s[a] * s[a];
          along += (o[a] + t * d[a] - p[a]) * q[a];
        }
        const double inv = len2 > 0 ? 1.0 / std::sqrt(len2) : 0.0;
        for (int a = 0; a < 3; ++a) out[a] = s[a] * inv;
        H[i] = 1;
        D[i] = along;
      }
    }, 4096);
  }

 // Hemisphere rays (mesh maps: texbake/meshmaps/rays.py), rays a point, cosine-weighted about
  // its normal (inward: about -normal), in packets of 8, the points cut over the cores.
  // Outward: value (n,) the share of rays that hit nothing within distance (ambient
  // occlusion, 1 open) and bent (n, 3) (or (0, 3): not asked) the mean unoccluded direction,
  // unit (the normal where every ray is occluded). Inward: value (n,) the mean distance to
  // the first hit, capped at distance (a miss counts as distance: thickness). Origins are
  // moved bias along their ray's side of the normal first; directions come from a
  // Hammersley set of rays points rotated per point (Cranley-Patterson, hashed from seed
  // and the point's row), so that neighbouring texels' noise does not correlate.
  void hemisphere(In<float, shape<-1, 3>> origins, In<float, shape<-1, 3>> normals, int rays, float distance, float bias,
                  uint32_t seed, bool inward, Out<float, nb::ndim<1>> value, Out<float, shape<-1, 3>> bent) const {
    const int64_t n = origins.shape(0);
    if (int64_t(normals.shape(0)) != n || int64_t(value.shape(0)) != n || (bent.shape(0) != 0 && int64_t(bent.shape(0)) != n))
      throw std::invalid_argument("hemisphere: normals (n, 3), value (n,), bent (n, 3) or (0, 3)");
    if (rays < 1) throw std::invalid_argument("hemisphere: rays must be at least 1");
    const float *o = origins.data(), *nr = normals.data();
    float *out = value.data(), *bout = bent.shape(0) ? bent.data() : nullptr;
    parallel_for(n, [&](int64_t begin, int64_t end) {
      for (int64_t i = begin; i < end; ++i) point(o + 3 * i, nr + 3 * i, rays, distance, bias, mix(seed, uint32_t(i)), inward, out[i],
                                                  bout ? bout + 3 * i : nullptr);
    }, 64);
  }

 private:
  static uint32_t mix(uint32_t seed, uint32_t i) {  // a 32-bit hash (lowbias32)
    uint32_t x = seed * 0x9E3779B9u ^ (i + 0x7F4A7C15u);
    x ^= x >> 16; x *= 0x7feb352du; x ^= x >> 15; x *= 0x846ca68bu; x ^= x >> 16;
    return x;
  }
  static float radical_inverse(uint32_t bits) {
    bits = (bits << 16) | (bits >> 16);
    bits = ((bits & 0x55555555u) << 1) | ((bits & 0xAAAAAAAAu) >> 1);
    bits = ((bits & 0x33333333u) << 2) | ((bits & 0xCCCCCCCCu) >> 2);
    bits = ((bits & 0x0F0F0F0Fu) << 4) | ((bits & 0xF0F0F0F0u) >> 4);
    bits = ((bits & 0x00FF00FFu) << 8) | ((bits & 0xFF00FF00u) >> 8);
    return float(bits) * 2.3283064365386963e-10f;
  }

  void point(const float* p, const float* normal, int rays, float distance, float bias, uint32_t hash, bool inward, float& value,
             float* bent) const {
    const float side = inward ? -1.0f : 1.0f;
    const float nx = side * normal[0], ny = side * normal[1], nz = side * normal[2];
    // an orthonormal basis about the ray side's normal (Duff et al. 2017)
    const float sign = std::copysign(1.0f, nz), a = -1.0f / (sign + nz), b = nx * ny * a;
    const float tx = 1.0f + sign * nx * nx * a, ty = sign * b, tz = -sign * nx;
    const float sx = b, sy = sign + ny * ny * a, sz = -ny;
    const float ox = p[0] + bias * nx, oy = p[1] + bias * ny, oz = p[2] + bias * nz;
    const float r1 = float(hash & 0xFFFFu) / 65536.0f, r2 = float(hash >> 16) / 65536.0f;
    double sum = 0.0, bx = 0.0, by = 0.0, bz = 0.0;
    for (int first = 0; first < rays; first += 8) {
      RayHit8 packet;
      int valid[8];
      for (int k = 0; k < 8; ++k) {
        const int j = first + k;
        valid[k] = j < rays ? -1 : 0;
        float u = (float(j) + 0.5f) / float(rays) + r1, v = radical_inverse(uint32_t(j)) + r2;
        u -= std::floor(u);
        v -= std::floor(v);
        const float radius = std::sqrt(u), phi = 6.2831853f * v, x = radius * std::cos(phi), y = radius * std::sin(phi);
        const float z = std::sqrt(std::fmax(0.0f, 1.0f - u));
        Ray8& r = packet.ray;
        r.org_x[k] = ox; r.org_y[k] = oy; r.org_z[k] = oz;
        r.dir_x[k] = x * tx + y * sx + z * nx; r.dir_y[k] = x * ty + y * sy + z * ny; r.dir_z[k] = x * tz + y * sz + z * nz;
        r.tnear[k] = 0.0f; r.time[k] = 0.0f; r.tfar[k] = distance;
        r.mask[k] = 0xFFFFFFFFu; r.id[k] = unsigned(k); r.flags[k] = 0u;
        packet.primID[k] = packet.geomID[k] = INVALID_ID;
      }
      if (inward) {
        api.rtcIntersect8(valid, scene_, &packet, nullptr);
      } else {
        api.rtcOccluded8(valid, scene_, &packet.ray, nullptr);  // tfar set to -inf where occluded
      }
      for (int k = 0; k < 8 && first + k < rays; ++k) {
        const Ray8& r = packet.ray;
        if (inward) {
          sum += std::fmin(r.tfar[k], distance);
        } else if (r.tfar[k] >= 0.0f) {
          sum += 1.0;
          bx += r.dir_x[k]; by += r.dir_y[k]; bz += r.dir_z[k];
        }
      }
    }
    value = float(sum / rays);
    if (bent) {
      const double length = std::sqrt(bx * bx + by * by + bz * bz);
      if (length > 0) {
        bent[0] = float(bx / length); bent[1] = float(by / length); bent[2] = float(bz / length);
      } else {
        bent[0] = normal[0]; bent[1] = normal[1]; bent[2] = normal[2];
      }
    }
  }

  RTCScene scene_ = nullptr;
};

}  // namespace

void bind_embree(nb::module_& m) {
  m.def("embree_open", &open_embree, nb::arg("path"), "Open the Embree 4 library at path (once a process).");
  nb::class_<Scene>(m, "EmbreeScene", "A robust Embree scene of one triangle mesh, committed.")
      .def(nb::init<In<float, shape<-1, 3>>, In<int64_t, shape<-1, 3>>>(), nb::arg("vertices"), nb::arg("faces"))
      .def("cast", &Scene::cast, nb::arg("origins"), nb::arg("directions"), nb::arg("face").noconvert(),
           nb::arg("tfar").noconvert(), Release(),
           "Fill face (n,) int32 (-1: no hit) and tfar (n,) float32 (in: each ray's bound) of the rays' first hits.")
      .def("cast_uv", &Scene::cast_uv, nb::arg("origins"), nb::arg("directions"), nb::arg("face").noconvert(),
           nb::arg("tfar").noconvert(), nb::arg("uv").noconvert(), Release(),
           "cast, over every core, also filling uv (n, 2) float32: each hit's barycentrics of the face's corners 1 and 2.")
      .def("project", &Scene::project, nb::arg("points"), nb::arg("normals"), nb::arg("cage"), nb::arg("front"), nb::arg("back"),
           nb::arg("centre"), nb::arg("scale"), nb::arg("src_normals"), nb::arg("src_faces"), nb::arg("hit").noconvert(),
           nb::arg("depth").noconvert(), nb::arg("normal").noconvert(), Release(),
           "High to low: each target point's ray onto the source (from the cage, or front along the normal), its hit, "
           "signed depth along the normal and the source's interpolated unit normal there.")
      .def("hemisphere", &Scene::hemisphere, nb::arg("origins"), nb::arg("normals"), nb::arg("rays"), nb::arg("distance"),
           nb::arg("bias"), nb::arg("seed"), nb::arg("inward"), nb::arg("value").noconvert(), nb::arg("bent").noconvert(), Release(),
           "Cosine-weighted hemisphere rays about each normal (inward: about -normal): value (n,) the open share (or the "
           "mean capped hit distance, inward), bent (n, 3) (or (0, 3)) the mean open direction.");
}

}  // namespace texbake
