/* pir_embree.c: the Embree 3/4 compatibility shim (see pir_embree.h). */
#include "pir_embree.h"

int pir_embree_major(void) { return PIR_EMBREE_MAJOR; }

unsigned int pir_invalid_geometry_id(void) { return RTC_INVALID_GEOMETRY_ID; }

#if PIR_EMBREE_MAJOR >= 4

/* Embree 4: a query context (instance stack) inside per-call arguments. */
#define PIR_INTERSECT(call, ...)                                 \
  do {                                                           \
    struct RTCRayQueryContext ctx;                               \
    struct RTCIntersectArguments args;                           \
    rtcInitRayQueryContext(&ctx);                                \
    rtcInitIntersectArguments(&args);                            \
    args.flags = RTC_RAY_QUERY_FLAG_INCOHERENT;                  \
    args.context = &ctx;                                         \
    call(__VA_ARGS__, &args);                                    \
  } while (0)

#define PIR_OCCLUDED(call, ...)                                  \
  do {                                                           \
    struct RTCRayQueryContext ctx;                               \
    struct RTCOccludedArguments args;                            \
    rtcInitRayQueryContext(&ctx);                                \
    rtcInitOccludedArguments(&args);                             \
    args.flags = RTC_RAY_QUERY_FLAG_INCOHERENT;                  \
    args.context = &ctx;                                         \
    call(__VA_ARGS__, &args);                                    \
  } while (0)

void pir_intersect1(RTCScene scene, struct RTCRayHit* rayhit) {
  PIR_INTERSECT(rtcIntersect1, scene, rayhit);
}
void pir_occluded1(RTCScene scene, struct RTCRay* ray) {
  PIR_OCCLUDED(rtcOccluded1, scene, ray);
}
void pir_intersect4(const int* valid, RTCScene scene, struct RTCRayHit4* rayhit) {
  PIR_INTERSECT(rtcIntersect4, valid, scene, rayhit);
}
void pir_occluded4(const int* valid, RTCScene scene, struct RTCRay4* ray) {
  PIR_OCCLUDED(rtcOccluded4, valid, scene, ray);
}
void pir_intersect8(const int* valid, RTCScene scene, struct RTCRayHit8* rayhit) {
  PIR_INTERSECT(rtcIntersect8, valid, scene, rayhit);
}
void pir_occluded8(const int* valid, RTCScene scene, struct RTCRay8* ray) {
  PIR_OCCLUDED(rtcOccluded8, valid, scene, ray);
}
void pir_intersect16(const int* valid, RTCScene scene, struct RTCRayHit16* rayhit) {
  PIR_INTERSECT(rtcIntersect16, valid, scene, rayhit);
}
void pir_occluded16(const int* valid, RTCScene scene, struct RTCRay16* ray) {
  PIR_OCCLUDED(rtcOccluded16, valid, scene, ray);
}

#else

/* Embree 3: an intersection context as the third argument (after valid and scene). */
static void pir_init_context(struct RTCIntersectContext* ctx) {
  rtcInitIntersectContext(ctx); /* sets instID[*] = RTC_INVALID_GEOMETRY_ID */
  ctx->flags = RTC_INTERSECT_CONTEXT_FLAG_INCOHERENT;
}

void pir_intersect1(RTCScene scene, struct RTCRayHit* rayhit) {
  struct RTCIntersectContext ctx;
  pir_init_context(&ctx);
  rtcIntersect1(scene, &ctx, rayhit);
}
void pir_occluded1(RTCScene scene, struct RTCRay* ray) {
  struct RTCIntersectContext ctx;
  pir_init_context(&ctx);
  rtcOccluded1(scene, &ctx, ray);
}
void pir_intersect4(const int* valid, RTCScene scene, struct RTCRayHit4* rayhit) {
  struct RTCIntersectContext ctx;
  pir_init_context(&ctx);
  rtcIntersect4(valid, scene, &ctx, rayhit);
}
void pir_occluded4(const int* valid, RTCScene scene, struct RTCRay4* ray) {
  struct RTCIntersectContext ctx;
  pir_init_context(&ctx);
  rtcOccluded4(valid, scene, &ctx, ray);
}
void pir_intersect8(const int* valid, RTCScene scene, struct RTCRayHit8* rayhit) {
  struct RTCIntersectContext ctx;
  pir_init_context(&ctx);
  rtcIntersect8(valid, scene, &ctx, rayhit);
}
void pir_occluded8(const int* valid, RTCScene scene, struct RTCRay8* ray) {
  struct RTCIntersectContext ctx;
  pir_init_context(&ctx);
  rtcOccluded8(valid, scene, &ctx, ray);
}
void pir_intersect16(const int* valid, RTCScene scene, struct RTCRayHit16* rayhit) {
  struct RTCIntersectContext ctx;
  pir_init_context(&ctx);
  rtcIntersect16(valid, scene, &ctx, rayhit);
}
void pir_occluded16(const int* valid, RTCScene scene, struct RTCRay16* ray) {
  struct RTCIntersectContext ctx;
  pir_init_context(&ctx);
  rtcOccluded16(valid, scene, &ctx, ray);
}

#endif
