/* Embree 3 on our ray sets, one thread: the reference the speed goals of issues 3 and 4
 * are stated against, measured on this machine in the same run as our own benchmarks.
 *
 * Reads a file of `benches/probes/vs_embree.rs` (the scene's triangles and spheres, and ray
 * sets with our answers), builds an Embree scene of one triangle mesh and one geometry
 * of sphere points, and times each set: single rays with rtcIntersect1, 8-wide packets
 * with rtcIntersect8 / rtcOccluded8 (the sets `vs_embree` writes). Each set is traced `passes` times
 * after one untimed pass; it prints every pass's rate and their median in Mrays/s, and
 * Embree's answer (hits, or unoccluded rays) beside ours. The set `build` (a file
 * `vs_embree` wrote with that set, holding the geometry alone) times rtcCommitScene
 * instead.
 *
 * benches/embree/run.sh builds and runs it; by hand:
 *   cc -O3 -march=native -o /tmp/embree_bench benches/embree/embree_bench.c -lembree3
 *   /tmp/embree_bench /tmp/bunny.rays 5
 */
#include <embree3/rtcore.h>
#include <math.h>
#include <stdint.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <time.h>

typedef struct {
    char name[17];
    uint32_t occlusion, width, count, answer;
    uint32_t *active;
    float *rays; /* count * width * 7 */
} Set;

static void *read_all(const char *path, size_t *len) {
    FILE *f = fopen(path, "rb");
    if (!f) {
        fprintf(stderr, "%s: cannot open\n", path);
        exit(2);
    }
    fseek(f, 0, SEEK_END);
    *len = (size_t)ftell(f);
    fseek(f, 0, SEEK_SET);
    void *buf = malloc(*len);
    if (fread(buf, 1, *len, f) != *len) {
        fprintf(stderr, "%s: short read\n", path);
        exit(2);
    }
    fclose(f);
    return buf;
}

static const unsigned char *cur;
static const unsigned char *end;
static uint32_t u32(void) {
    uint32_t v;
    if (cur + 4 > end) {
        fprintf(stderr, "truncated ray file\n");
        exit(2);
    }
    memcpy(&v, cur, 4);
    cur += 4;
    return v;
}
static float f32(void) {
    uint32_t v = u32();
    float f;
    memcpy(&f, &v, 4);
    return f;
}

static double now(void) {
    struct timespec ts;
    clock_gettime(CLOCK_MONOTONIC, &ts);
    return ts.tv_sec + ts.tv_nsec * 1e-9;
}

static float tmin;

/* One pass over a set; returns Embree's answer. */
static uint32_t trace(RTCScene scene, const Set *s) {
    struct RTCIntersectContext ctx;
    rtcInitIntersectContext(&ctx);
    /* EMBREE_COHERENT=1: tell Embree the packets are coherent (camera rays, shadow rays
       to one light); the default context says incoherent. */
    if (getenv("EMBREE_COHERENT") && strcmp(getenv("EMBREE_COHERENT"), "1") == 0)
        ctx.flags = RTC_INTERSECT_CONTEXT_FLAG_COHERENT;
    uint32_t answer = 0;
    for (uint32_t p = 0; p < s->count; p++) {
        const float *r = s->rays + (size_t)p * s->width * 7;
        uint32_t m = s->active[p];
        if (s->width == 1) { /* closest hit only: `main` rejects single-ray occlusion sets */
            struct RTCRayHit rh;
            memset(&rh, 0, sizeof rh);
            rh.ray.org_x = r[0], rh.ray.org_y = r[1], rh.ray.org_z = r[2];
            rh.ray.dir_x = r[3], rh.ray.dir_y = r[4], rh.ray.dir_z = r[5];
            rh.ray.tnear = tmin, rh.ray.tfar = r[6], rh.ray.mask = -1;
            rh.hit.geomID = RTC_INVALID_GEOMETRY_ID;
            rtcIntersect1(scene, &ctx, &rh);
            answer += rh.hit.geomID != RTC_INVALID_GEOMETRY_ID;
            continue;
        }
        int valid[8];
        if (s->occlusion) {
            struct RTCRay8 ray __attribute__((aligned(32)));
            for (int k = 0; k < 8; k++) {
                const float *q = r + k * 7;
                valid[k] = (m >> k & 1) ? -1 : 0;
                ray.org_x[k] = q[0], ray.org_y[k] = q[1], ray.org_z[k] = q[2];
                ray.dir_x[k] = q[3], ray.dir_y[k] = q[4], ray.dir_z[k] = q[5];
                ray.tnear[k] = tmin, ray.tfar[k] = q[6], ray.time[k] = 0;
                ray.mask[k] = -1, ray.id[k] = 0, ray.flags[k] = 0;
            }
            rtcOccluded8(valid, scene, &ctx, &ray);
            for (int k = 0; k < 8; k++)
                answer += valid[k] && ray.tfar[k] >= 0.0f;
        } else {
            struct RTCRayHit8 rh __attribute__((aligned(32)));
            for (int k = 0; k < 8; k++) {
                const float *q = r + k * 7;
                valid[k] = (m >> k & 1) ? -1 : 0;
                rh.ray.org_x[k] = q[0], rh.ray.org_y[k] = q[1], rh.ray.org_z[k] = q[2];
                rh.ray.dir_x[k] = q[3], rh.ray.dir_y[k] = q[4], rh.ray.dir_z[k] = q[5];
                rh.ray.tnear[k] = tmin, rh.ray.tfar[k] = q[6], rh.ray.time[k] = 0;
                rh.ray.mask[k] = -1, rh.ray.id[k] = 0, rh.ray.flags[k] = 0;
                rh.hit.geomID[k] = RTC_INVALID_GEOMETRY_ID;
            }
            rtcIntersect8(valid, scene, &ctx, &rh);
            for (int k = 0; k < 8; k++)
                answer += valid[k] && rh.hit.geomID[k] != RTC_INVALID_GEOMETRY_ID;
        }
    }
    return answer;
}

static int cmp_double(const void *a, const void *b) {
    double x = *(const double *)a, y = *(const double *)b;
    return (x > y) - (x < y);
}

/* A scene of one triangle mesh: `ntri` triangles of nine floats each, not committed. */
static RTCScene triangle_scene(RTCDevice device, const float *tri, uint32_t ntri) {
    RTCScene scene = rtcNewScene(device);
    if (ntri) {
        RTCGeometry g = rtcNewGeometry(device, RTC_GEOMETRY_TYPE_TRIANGLE);
        float *v = rtcSetNewGeometryBuffer(g, RTC_BUFFER_TYPE_VERTEX, 0, RTC_FORMAT_FLOAT3,
                                           3 * sizeof(float), 3 * (size_t)ntri);
        unsigned *idx = rtcSetNewGeometryBuffer(g, RTC_BUFFER_TYPE_INDEX, 0, RTC_FORMAT_UINT3,
                                                3 * sizeof(unsigned), ntri);
        memcpy(v, tri, 9 * (size_t)ntri * sizeof(float));
        for (size_t i = 0; i < 3 * (size_t)ntri; i++)
            idx[i] = (unsigned)i;
        rtcCommitGeometry(g);
        rtcAttachGeometry(scene, g);
        rtcReleaseGeometry(g);
    }
    return scene;
}

int main(int argc, char **argv) {
    if (argc < 2) {
        fprintf(stderr, "usage: embree_bench RAYS [passes] [set]\n");
        return 2;
    }
    int passes = argc > 2 ? atoi(argv[2]) : 5;
    const char *only = argc > 3 ? argv[3] : NULL;
    if (passes < 1 || passes > 1000) {
        fprintf(stderr, "passes: %s is not in 1..=1000\n", argv[2]);
        return 2;
    }
    size_t len;
    unsigned char *buf = read_all(argv[1], &len);
    cur = buf, end = buf + len;

    RTCDevice device = rtcNewDevice(getenv("EMBREE_CONFIG") ? getenv("EMBREE_CONFIG") : "threads=1");
    if (!device) {
        fprintf(stderr, "rtcNewDevice failed: %d\n", rtcGetDeviceError(NULL));
        return 1;
    }
    uint32_t ntri = u32();
    float *tri = malloc(9 * (size_t)ntri * sizeof(float) + 1);
    for (size_t i = 0; i < 9 * (size_t)ntri; i++)
        tri[i] = f32();
    /* The set `build`: the triangles' scene built `passes` times after an untimed build,
     * each time from a new scene (the time of rtcCommitScene alone). */
    if (only && strcmp(only, "build") == 0) {
        double *ms = malloc((passes + 1) * sizeof(double));
        printf("build    %u triangles:", ntri);
        for (int k = 0; k <= passes; k++) {
            RTCScene s = triangle_scene(device, tri, ntri);
            double a = now();
            rtcCommitScene(s);
            ms[k] = (now() - a) * 1e3;
            rtcReleaseScene(s);
            if (k > 0)
                printf(" %.1f", ms[k]);
        }
        qsort(ms + 1, passes, sizeof(double), cmp_double);
        double med = passes % 2 ? ms[1 + passes / 2]
                                : 0.5 * (ms[passes / 2] + ms[1 + passes / 2]);
        printf(" ms; median %.1f ms (one thread)\n", med);
        free(ms);
        rtcReleaseDevice(device);
        return 0;
    }
    RTCScene scene = triangle_scene(device, tri, ntri);
    uint32_t nsph = u32();
    /* EMBREE_MESH_ONLY=1: leave the spheres out (less work than ours: an upper bound). */
    int mesh_only = getenv("EMBREE_MESH_ONLY") && strcmp(getenv("EMBREE_MESH_ONLY"), "1") == 0;
    if (mesh_only) {
        cur += 16 * (size_t)nsph;
        nsph = 0;
    }
    if (nsph) {
        RTCGeometry g = rtcNewGeometry(device, RTC_GEOMETRY_TYPE_SPHERE_POINT);
        float *v = rtcSetNewGeometryBuffer(g, RTC_BUFFER_TYPE_VERTEX, 0, RTC_FORMAT_FLOAT4,
                                           4 * sizeof(float), nsph);
        for (size_t i = 0; i < 4 * (size_t)nsph; i++)
            v[i] = f32();
        rtcCommitGeometry(g);
        rtcAttachGeometry(scene, g);
        rtcReleaseGeometry(g);
    }
    double t0 = now();
    rtcCommitScene(scene);
    double build = now() - t0;
    if (rtcGetDeviceError(device) != RTC_ERROR_NONE) {
        fprintf(stderr, "Embree error %d\n", rtcGetDeviceError(device));
        return 1;
    }
    printf("embree %d.%d.%d: %u triangles, %u spheres, build %.2f ms (one thread)\n",
           (int)rtcGetDeviceProperty(device, RTC_DEVICE_PROPERTY_VERSION_MAJOR),
           (int)rtcGetDeviceProperty(device, RTC_DEVICE_PROPERTY_VERSION_MINOR),
           (int)rtcGetDeviceProperty(device, RTC_DEVICE_PROPERTY_VERSION_PATCH), ntri, nsph,
           build * 1e3);

    tmin = f32();
    uint32_t nsets = u32();
    for (uint32_t i = 0; i < nsets; i++) {
        Set s;
        memcpy(s.name, cur, 16);
        s.name[16] = 0;
        cur += 16;
        s.occlusion = u32(), s.width = u32(), s.count = u32(), s.answer = u32();
        if ((s.width != 1 && s.width != 8) || (s.width == 1 && s.occlusion)) {
            fprintf(stderr, "set %s: width %u is not 8, or 1 for closest hits\n", s.name,
                    s.width);
            return 2;
        }
        s.active = malloc(s.count * sizeof(uint32_t));
        s.rays = malloc((size_t)s.count * s.width * 7 * sizeof(float));
        uint64_t nrays = 0;
        for (uint32_t p = 0; p < s.count; p++) {
            s.active[p] = u32();
            nrays += __builtin_popcount(s.active[p]);
            for (uint32_t k = 0; k < s.width * 7; k++)
                s.rays[(size_t)p * s.width * 7 + k] = f32();
        }
        if (only && strcmp(only, s.name) != 0)
            continue;
        uint32_t answer = trace(scene, &s);
        double *rate = malloc(passes * sizeof(double));
        printf("%-13s %s, %lu rays:", s.name, s.width == 1 ? "single" : "8-wide",
               (unsigned long)nrays);
        for (int k = 0; k < passes; k++) {
            double a = now();
            trace(scene, &s);
            rate[k] = nrays / (now() - a) * 1e-6;
            printf(" %.1f", rate[k]);
        }
        qsort(rate, passes, sizeof(double), cmp_double);
        double med = passes % 2 ? rate[passes / 2]
                                : 0.5 * (rate[passes / 2 - 1] + rate[passes / 2]);
        printf("; median %.1f Mrays/s; %s %u (ours %u)\n", med,
               s.occlusion ? "unoccluded" : "hits", answer, s.answer);
        free(rate);
        free(s.active);
        free(s.rays);
    }
    rtcReleaseScene(scene);
    rtcReleaseDevice(device);
    free(tri);
    free(buf);
    return 0;
}
