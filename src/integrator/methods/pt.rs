//! `pt`: the path tracer ([`PathTracer`]), pir's ground truth. No parameters besides the
//! path length (`--max-depth`).

use super::{MethodSpec, Parameter, Settings};
use crate::integrator::{Integrator, PathTracer};

pub struct Pt;

impl MethodSpec for Pt {
    fn name(&self) -> &'static str {
        "pt"
    }
    fn description(&self) -> &'static str {
        "path tracer with next-event estimation and MIS: the ground truth"
    }
    fn parameters(&self) -> &'static [Parameter] {
        &[]
    }
    fn integrator(&self, _: &Settings) -> Box<dyn Integrator> {
        Box::new(PathTracer)
    }
}
