/* pir_embree.h: a small C shim that hides the differences between Embree 3 and Embree 4.
 *
 * build.rs defines PIR_EMBREE_MAJOR (3 or 4) from the installed rtcore_config.h. Both
 * versions get the same entry points:
 *   - pir_intersect{1,4,8,16} / pir_occluded{1,4,8,16}: Embree 3 takes an
 *     RTCIntersectContext as third argument, Embree 4 an optional RTCIntersectArguments /
 *     RTCOccludedArguments as last argument. The context/arguments initialisers
 *     (rtcInitIntersectContext, rtcInitIntersectArguments, rtcInitOccludedArguments) are
 *     inline functions that bindgen cannot see, so they are called here, in C.
 *   - Every query uses the INCOHERENT flag (COHERENT measured ~2x slower for divergent
 *     shadow rays on this machine).
 *   - pir_invalid_geometry_id(): RTC_INVALID_GEOMETRY_ID, a macro bindgen drops.
 *
 * Packet alignment (checked by the caller): rayhit/ray and valid for 4-wide 16 bytes,
 * 8-wide 32 bytes, 16-wide 64 bytes. Valid masks: -1 active, 0 inactive.
 */
#ifndef PIR_EMBREE_H
#define PIR_EMBREE_H

#if !defined(PIR_EMBREE_MAJOR)
#error "PIR_EMBREE_MAJOR must be defined by build.rs (3 or 4)"
#endif

#if PIR_EMBREE_MAJOR >= 4
#include <embree4/rtcore.h>
#else
#include <embree3/rtcore.h>
#endif

#ifdef __cplusplus
extern "C" {
#endif

/* The Embree major version the shim was compiled against. */
int pir_embree_major(void);

/* RTC_INVALID_GEOMETRY_ID (all bits set). */
unsigned int pir_invalid_geometry_id(void);

void pir_intersect1(RTCScene scene, struct RTCRayHit* rayhit);
void pir_occluded1(RTCScene scene, struct RTCRay* ray);

void pir_intersect4(const int* valid, RTCScene scene, struct RTCRayHit4* rayhit);
void pir_occluded4(const int* valid, RTCScene scene, struct RTCRay4* ray);

void pir_intersect8(const int* valid, RTCScene scene, struct RTCRayHit8* rayhit);
void pir_occluded8(const int* valid, RTCScene scene, struct RTCRay8* ray);

void pir_intersect16(const int* valid, RTCScene scene, struct RTCRayHit16* rayhit);
void pir_occluded16(const int* valid, RTCScene scene, struct RTCRay16* ray);

#ifdef __cplusplus
}
#endif

#endif /* PIR_EMBREE_H */
