/* Trace one exported ray set (`SPECTRACE_EXPORT_RAYS=DIR`, see `traversal_table`) with Embree 4
 * robust, calling `rtcIntersect1` / `rtcOccluded1` from C in a plain loop: Embree's rate without
 * embreex's Cython loop and its per-ray copies, which `embree_bvh.py` can only bracket (its
 * "net" figure subtracts a root-miss query in full, Embree's own set-up and root test included;
 * its "gross" figure keeps the loop). The same scene as embreex builds (robust flag, default
 * MEDIUM quality, three vertices per triangle) from the library its wheel ships. An optional
 * comparison tool outside the project, like the Python scripts beside it; the Embree 4 API
 * declarations it needs are written out below (the wheel ships no headers).
 *
 *     L=$(python3 -c 'import embreex,os;print(os.path.dirname(embreex.__file__))')/../embreex.libs
 *     gcc -O2 -o /tmp/embree_direct xtask/compare/embree_direct.c $L/libembree4-*.so.4 -Wl,-rpath,$L
 *     taskset -c 1 /tmp/embree_direct /tmp/rays terrain_2k incoherent 8 [--any]
 *     EMBREE_CONFIG=max_isa=avx2 taskset -c 1 /tmp/embree_direct ...   (Embree's AVX2 kernels)
 *
 * Prints M rays/s of this thread's CPU time over all passes and the hit count, in the format of
 * `crates/geometry/examples/trace_exported.rs`, so the two alternate in one A/B script. Under
 * `valgrind --tool=cachegrind --branch-sim=yes` at 1 and 3 passes, half the difference over the
 * ray count is Embree's instructions, branches and mispredictions per ray (its AVX2 kernels:
 * valgrind has no AVX-512). `--miss` traces against one far-away triangle: the fixed cost of a query.
 */
#define _GNU_SOURCE
#include <math.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <time.h>

typedef struct RTCDeviceTy *RTCDevice;
typedef struct RTCSceneTy *RTCScene;
typedef struct RTCGeometryTy *RTCGeometry;

/* Embree 4's RTCRay, RTCHit and RTCRayHit (rtcore_ray.h), 16-byte aligned. The hit is padded:
 * builds with more instance levels append fields after `instID`, which stay unread here. */
struct RTCRay {
    float org_x, org_y, org_z, tnear;
    float dir_x, dir_y, dir_z, time;
    float tfar;
    unsigned int mask, id, flags;
} __attribute__((aligned(16)));

struct RTCHit {
    float Ng_x, Ng_y, Ng_z, u, v;
    unsigned int primID, geomID;
    unsigned int instID[1];
    unsigned int padding[8];
} __attribute__((aligned(16)));

struct RTCRayHit {
    struct RTCRay ray;
    struct RTCHit hit;
};

enum { RTC_GEOMETRY_TYPE_TRIANGLE = 0, RTC_BUFFER_TYPE_INDEX = 0, RTC_BUFFER_TYPE_VERTEX = 1 };
enum { RTC_FORMAT_UINT3 = 0x5003, RTC_FORMAT_FLOAT3 = 0x9003, RTC_SCENE_FLAG_ROBUST = 1 << 2 };
#define RTC_INVALID_GEOMETRY_ID ((unsigned int)-1)

RTCDevice rtcNewDevice(const char *config);
RTCScene rtcNewScene(RTCDevice device);
void rtcSetSceneFlags(RTCScene scene, int flags);
RTCGeometry rtcNewGeometry(RTCDevice device, int type);
void *rtcSetNewGeometryBuffer(RTCGeometry geometry, int type, unsigned int slot, int format, size_t byteStride,
                              size_t itemCount);
void rtcCommitGeometry(RTCGeometry geometry);
unsigned int rtcAttachGeometry(RTCScene scene, RTCGeometry geometry);
void rtcReleaseGeometry(RTCGeometry geometry);
void rtcCommitScene(RTCScene scene);
void rtcIntersect1(RTCScene scene, struct RTCRayHit *rayhit, void *args);
void rtcOccluded1(RTCScene scene, struct RTCRay *ray, void *args);

static float *read_floats(const char *path, size_t *count) {
    FILE *f = fopen(path, "rb");
    if (!f) {
        fprintf(stderr, "error: cannot open %s\n", path);
        exit(1);
    }
    fseek(f, 0, SEEK_END);
    long bytes = ftell(f);
    fseek(f, 0, SEEK_SET);
    float *data = malloc(bytes);
    if (!data || fread(data, 1, bytes, f) != (size_t)bytes) {
        fprintf(stderr, "error: cannot read %s\n", path);
        exit(1);
    }
    fclose(f);
    *count = bytes / sizeof(float);
    return data;
}

static double thread_cpu_seconds(void) {
    struct timespec ts;
    clock_gettime(CLOCK_THREAD_CPUTIME_ID, &ts);
    return ts.tv_sec + ts.tv_nsec * 1e-9;
}

int main(int argc, char **argv) {
    if (argc < 5) {
        fprintf(stderr, "usage: embree_direct DIR SCENE primary|incoherent PASSES [--any] [--miss]\n");
        return 2;
    }
    int any = 0, miss = 0;
    for (int i = 5; i < argc; i++) {
        any |= strcmp(argv[i], "--any") == 0;
        miss |= strcmp(argv[i], "--miss") == 0;
    }
    char path[4096];
    size_t n_floats;
    snprintf(path, sizeof path, "%s/%s.tris", argv[1], argv[2]);
    float *tris = read_floats(path, &n_floats);
    size_t n_tris = n_floats / 9;
    if (miss) {
        /* One far-away triangle every ray misses at the root, as `embree_bvh.py`'s. */
        float far[9] = {1e6f, 1e6f, 1e6f, 1e6f + 1, 1e6f, 1e6f, 1e6f, 1e6f + 1, 1e6f};
        memcpy(tris, far, sizeof far);
        n_tris = 1;
    }
    snprintf(path, sizeof path, "%s/%s_%s.rays", argv[1], argv[2], argv[3]);
    float *rays = read_floats(path, &n_floats);
    size_t n_rays = n_floats / 6;
    int passes = atoi(argv[4]);

    /* EMBREE_CONFIG, e.g. "max_isa=avx2", is passed to the device (Embree picks its widest ISA). */
    RTCDevice device = rtcNewDevice(getenv("EMBREE_CONFIG"));
    RTCScene scene = rtcNewScene(device);
    rtcSetSceneFlags(scene, RTC_SCENE_FLAG_ROBUST);
    RTCGeometry geom = rtcNewGeometry(device, RTC_GEOMETRY_TYPE_TRIANGLE);
    float *v = rtcSetNewGeometryBuffer(geom, RTC_BUFFER_TYPE_VERTEX, 0, RTC_FORMAT_FLOAT3, 12, 3 * n_tris);
    unsigned int *idx = rtcSetNewGeometryBuffer(geom, RTC_BUFFER_TYPE_INDEX, 0, RTC_FORMAT_UINT3, 12, n_tris);
    memcpy(v, tris, 36 * n_tris);
    for (size_t i = 0; i < 3 * n_tris; i++) idx[i] = (unsigned int)i;
    rtcCommitGeometry(geom);
    rtcAttachGeometry(scene, geom);
    rtcReleaseGeometry(geom);
    rtcCommitScene(scene);

    long hits = 0;
    double t0 = thread_cpu_seconds();
    for (int pass = 0; pass < passes; pass++) {
        for (size_t i = 0; i < n_rays; i++) {
            const float *r = rays + 6 * i;
            struct RTCRayHit rh;
            rh.ray.org_x = r[0], rh.ray.org_y = r[1], rh.ray.org_z = r[2], rh.ray.tnear = 0.0f;
            rh.ray.dir_x = r[3], rh.ray.dir_y = r[4], rh.ray.dir_z = r[5], rh.ray.time = 0.0f;
            rh.ray.tfar = INFINITY, rh.ray.mask = ~0u, rh.ray.id = 0, rh.ray.flags = 0;
            if (any) {
                rtcOccluded1(scene, &rh.ray, NULL);
                hits += rh.ray.tfar < 0.0f; /* set to -inf when occluded */
            } else {
                rh.hit.geomID = RTC_INVALID_GEOMETRY_ID;
                rh.hit.instID[0] = RTC_INVALID_GEOMETRY_ID;
                rtcIntersect1(scene, &rh, NULL);
                hits += rh.hit.geomID != RTC_INVALID_GEOMETRY_ID;
            }
        }
    }
    double seconds = thread_cpu_seconds() - t0;
    printf("%s %s%s %.3f M/s over %d passes; %ld hits\n", argv[2], argv[3], any ? " any" : "",
           (double)n_rays * passes / seconds / 1e6, passes, hits);
    return 0;
}
