// Embree scenes built and cast from here (texbake/sampling/rays.py), through the Embree 4
// library that embreex ships (opened by its path with dlopen; embreex's own binding copies a
// scene element by element through Python, about 1.3 s a million faces). The scene, its
// flags and its rays are set up as embreex sets them (robust scene, float3 vertices with a
// stride of 16 bytes, uint3 faces, one ray at a time with tnear 0), so the same rays find the
// same faces. Only the part of Embree's API used here is declared, as include/embree4 has it.
#include <dlfcn.h>
#include <unistd.h>
#include <nanobind/stl/string.h>

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

 private:
  RTCScene scene_ = nullptr;
};

}  // namespace

void bind_embree(nb::module_& m) {
  m.def("embree_open", &open_embree, nb::arg("path"), "Open the Embree 4 library at path (once a process).");
  nb::class_<Scene>(m, "EmbreeScene", "A robust Embree scene of one triangle mesh, committed.")
      .def(nb::init<In<float, shape<-1, 3>>, In<int64_t, shape<-1, 3>>>(), nb::arg("vertices"), nb::arg("faces"))
      .def("cast", &Scene::cast, nb::arg("origins"), nb::arg("directions"), nb::arg("face").noconvert(),
           nb::arg("tfar").noconvert(), Release(),
           "Fill face (n,) int32 (-1: no hit) and tfar (n,) float32 (in: each ray's bound) of the rays' first hits.");
}

}  // namespace texbake
