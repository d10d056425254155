#include "crs/crs_operation.hpp"

#include <proj.h>

#include <memory>
#include <set>

#include "rv/field/error.hpp"

namespace rv::detail {
namespace {

struct ContextDeleter {
  void operator()(PJ_CONTEXT* c) const { proj_context_destroy(c); }
};
struct ObjectDeleter {
  void operator()(PJ* p) const { proj_destroy(p); }
};
struct ListDeleter {
  void operator()(PJ_OBJ_LIST* l) const { proj_list_destroy(l); }
};
struct FactoryDeleter {
  void operator()(PJ_OPERATION_FACTORY_CONTEXT* f) const { proj_operation_factory_context_destroy(f); }
};
using Context = std::unique_ptr<PJ_CONTEXT, ContextDeleter>;
using Object = std::unique_ptr<PJ, ObjectDeleter>;
using List = std::unique_ptr<PJ_OBJ_LIST, ListDeleter>;
using Factory = std::unique_ptr<PJ_OPERATION_FACTORY_CONTEXT, FactoryDeleter>;

Object crs_of(PJ_CONTEXT* ctx, const OGRSpatialReference& srs) {
  const char* options[] = {"FORMAT=WKT2_2019", nullptr};
  char* wkt = nullptr;
  if (srs.exportToWkt(&wkt, options) != OGRERR_NONE || wkt == nullptr) {
    CPLFree(wkt);
    throw Error(ErrorKind::invalid_input, "a layer's CRS cannot be written as WKT for PROJ");
  }
  Object crs(proj_create(ctx, wkt));
  CPLFree(wkt);
  if (!crs) throw Error(ErrorKind::invalid_input, "PROJ does not read a layer's CRS");
  return crs;
}

// An operation is a conversion when it changes no datum: a conversion itself, or a chain of them.
bool is_conversion(PJ_CONTEXT* ctx, const PJ* op) {
  const PJ_TYPE type = proj_get_type(op);
  if (type == PJ_TYPE_CONVERSION) return true;
  if (type != PJ_TYPE_CONCATENATED_OPERATION) return false;
  const int steps = proj_concatoperation_get_step_count(ctx, op);
  for (int k = 0; k < steps; ++k) {
    const Object step(proj_concatoperation_get_step(ctx, op, k));
    if (!step || !is_conversion(ctx, step.get())) return false;
  }
  return true;
}

}  // namespace

ChosenOperation choose_operation(const OGRSpatialReference& from, const OGRSpatialReference& to, double west,
                                 double south, double east, double north) {
  const Context ctx(proj_context_create());
  // PROJ says on stderr which grids an operation lacks; that is stated in the result instead.
  proj_log_func(ctx.get(), nullptr, [](void*, int, const char*) {});
  const Object source = crs_of(ctx.get(), from), target = crs_of(ctx.get(), to);
  // Whole-area operations first: one whose area of use only meets the data's would carry the
  // part outside it too.
  for (const PROJ_SPATIAL_CRITERION criterion :
       {PROJ_SPATIAL_CRITERION_STRICT_CONTAINMENT, PROJ_SPATIAL_CRITERION_PARTIAL_INTERSECTION}) {
    const Factory factory(proj_create_operation_factory_context(ctx.get(), nullptr));
    proj_operation_factory_context_set_area_of_interest(ctx.get(), factory.get(), west, south, east, north);
    proj_operation_factory_context_set_spatial_criterion(ctx.get(), factory.get(), criterion);
    proj_operation_factory_context_set_grid_availability_use(ctx.get(), factory.get(),
                                                             PROJ_GRID_AVAILABILITY_USED_FOR_SORTING);
    const List ops(proj_create_operations(ctx.get(), source.get(), target.get(), factory.get()));
    const int count = ops ? proj_list_get_count(ops.get()) : 0;
    std::vector<Object> unusable;  // ranked before the chosen one but missing something
    for (int i = 0; i < count; ++i) {
      Object op(proj_list_get(ctx.get(), ops.get(), i));
      if (!op) continue;
      if (!proj_coordoperation_is_instantiable(ctx.get(), op.get())) {
        unusable.push_back(std::move(op));
        continue;
      }
      ChosenOperation chosen;
      chosen.name = proj_get_name(op.get()) ? proj_get_name(op.get()) : "?";
      const char* definition = proj_as_proj_string(ctx.get(), op.get(), PJ_PROJ_5, nullptr);
      if (definition == nullptr) continue;
      chosen.definition = definition;
      chosen.conversion = is_conversion(ctx.get(), op.get());
      chosen.ballpark = proj_coordoperation_has_ballpark_transformation(ctx.get(), op.get()) != 0;
      chosen.accuracy = chosen.conversion ? 0.0 : proj_coordoperation_get_accuracy(ctx.get(), op.get());
      if (!(chosen.accuracy >= 0.0)) chosen.accuracy = -1.0;
      // The grids that more accurate operations lack (PROJ sorts those missing grids last, so
      // they are listed among all that were passed over, ranked before or after).
      std::set<std::string> grids;
      for (int j = i + 1; j < count; ++j) {
        Object other(proj_list_get(ctx.get(), ops.get(), j));
        if (other && !proj_coordoperation_is_instantiable(ctx.get(), other.get())) unusable.push_back(std::move(other));
      }
      for (const Object& other : unusable) {
        const double better = proj_coordoperation_get_accuracy(ctx.get(), other.get());
        if (!(better >= 0.0) || (chosen.accuracy >= 0.0 && better >= chosen.accuracy && !chosen.ballpark)) continue;
        const int used = proj_coordoperation_get_grid_used_count(ctx.get(), other.get());
        for (int g = 0; g < used; ++g) {
          const char *short_name = nullptr, *full_name = nullptr, *package = nullptr, *url = nullptr;
          int direct = 0, open_license = 0, available = 0;
          if (proj_coordoperation_get_grid_used(ctx.get(), other.get(), g, &short_name, &full_name, &package, &url,
                                                &direct, &open_license, &available) &&
              !available && short_name != nullptr)
            grids.insert(short_name);
        }
      }
      chosen.missing_grids.assign(grids.begin(), grids.end());
      return chosen;
    }
  }
  throw Error(ErrorKind::invalid_input, "PROJ knows no operation between a layer's CRS and the target CRS");
}

}  // namespace rv::detail
