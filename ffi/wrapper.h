/* wrapper.h: the single header bindgen reads. It sees the installed Embree headers (so the
 * struct layouts match the library that is linked) and the pir shim declarations. */
#include "pir_embree.h"
