//! `pqm levels` — placeholder: the real module is written on another branch.
//! The interface is fixed: `Args` (clap) and `run(args, ctx)`.

use crate::ctx::Ctx;

/// Write several levels of a .pqm file as glTF (not implemented yet).
#[derive(clap::Args, Debug)]
pub struct Args {}

/// Not implemented yet.
pub fn run(_args: &Args, _ctx: &Ctx) -> anyhow::Result<()> {
    anyhow::bail!("pqm levels is not implemented yet")
}
