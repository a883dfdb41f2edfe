//! Regenerates the built-in decal textures' PNGs (level 0 of every image of
//! [`sandbox::decal_textures::all`]) into `assets/decals/`, or into the directory given as the only
//! argument:
//!
//! ```sh
//! cargo run -p sandbox --bin gen_decal_textures            # assets/decals/ of the workspace
//! cargo run -p sandbox --bin gen_decal_textures -- out/dir  # somewhere else
//! ```
//!
//! Run it after changing the generator; the unit test `pngs_in_assets_match_the_generator` fails
//! until the committed copies match it byte for byte.

#![forbid(unsafe_code)]

use std::path::PathBuf;
use std::process::ExitCode;

use sandbox::decal_textures::{assets_dir, write_pngs};

fn main() -> ExitCode {
    let usage = || format!("usage: gen_decal_textures [DIR]   (DIR defaults to {})", assets_dir().display());
    let args: Vec<_> = std::env::args_os().skip(1).collect();
    let dir = match args.as_slice() {
        [] => assets_dir(),
        [flag] if flag == "-h" || flag == "--help" => {
            println!("{}", usage());
            return ExitCode::SUCCESS;
        }
        [dir] => PathBuf::from(dir),
        _ => {
            eprintln!("{}", usage());
            return ExitCode::from(2);
        }
    };
    match write_pngs(&dir) {
        Ok(written) => {
            for path in written {
                println!("{}", path.display());
            }
            ExitCode::SUCCESS
        }
        Err(error) => {
            eprintln!("gen_decal_textures: {error:#}");
            ExitCode::FAILURE
        }
    }
}
