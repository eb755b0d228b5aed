"""Named rows and columns of the flat arrays the kernels share.

Points (raygen.surface_soa; the G-buffer's `soa`): one row per coordinate, one column per
point, so that a loop over points reads unit-stride rows and vectorises.

Light rows (LIGHT_ROW floats): one per analytic light (light_sampling.analytic_rows) or per emitting
triangle (shading.LightSet), in the same columns, so that one branch-free loop
(light_sampling._picked_rays) can sample whichever kind a point picked."""

# a point's rows: position, shading normal, true (geometric) normal
PX, PY, PZ, NX, NY, NZ, GX, GY, GZ = range(9)
POINT_ROWS = 9

# an analytic light's row: position, direction towards a sun, a spot's cone (cos of the outer
# angle and 1 / (cos inner - cos outer); a point light's never cuts: -2 and 1), the cosine of a
# sun's angular radius, 1 for a sun, radiance (intensity, or a sun's irradiance)
POSITION, TO_SUN, CONE_COS, CONE_SCALE, SUN_COS, IS_SUN, RADIANCE = 0, 3, 6, 7, 8, 9, 10
# an emitting triangle's row: a vertex, the two edges from it, the face normal, Le x area /
# the pick's probability within its cluster, 1 if it emits from both sides, and the density of
# its points among its cluster's (the pick's probability / area: multiple importance sampling)
VERTEX, EDGE1, EDGE2, FACE_NORMAL, EMISSION, TWO_SIDED, AREA_PDF = 0, 3, 6, 9, 12, 15, 16
LIGHT_ROW = 17
GPU_LIGHT_ROW = 16  # the columns the Slang backend uploads (its rows are four float4)

# a picked light's row (light_sampling._gather_picked) adds: 1 / the pick's probability, 1 for an emitter
INV_PROB, IS_EMITTER = 17, 18
PICKED_ROWS = 19
