//! `--rrd`, `--connect` and `--spawn`: where a command's rerun data go, defined once and
//! flattened into each command that publishes (as `rerun::clap::RerunArgs` is in rerun's
//! examples), with the one [`ViewerArgs::sink`] that turns them into a [`RerunSink`].
//!
//! The commands do not offer the same ways out (`predict` only saves an .rrd, only `replay`
//! spawns a viewer) and each says what its recording holds, so each command names its
//! [`Offer`]: the flags it takes and their help. clap's derive cannot leave a field's flag
//! out, hence `Args` by hand here.

use std::marker::PhantomData;
use std::path::PathBuf;

use clap::{Arg, ArgAction, ArgMatches, Args, FromArgMatches};
use heatrun_rerun::RerunSink;

/// The viewer flags one command takes, and what its help says of them.
pub trait Offer {
    /// `--rrd`'s value name and help (every command that publishes can save an .rrd).
    const RRD: (&'static str, &'static str);
    /// `--connect`'s help, where the command streams to a running viewer.
    const CONNECT: Option<&'static str> = None;
    /// `--spawn`'s help, where the command starts a viewer of its own.
    const SPAWN: Option<&'static str> = None;
    /// Whether `--rrd` and `--connect` refuse each other. Where they do not, the viewer
    /// wins (`replay` has always taken both and sent to the viewer).
    const EXCLUSIVE: bool = false;
}

/// The viewer flags as given, for the command whose [`Offer`] is `O`.
#[derive(Debug, Clone, PartialEq, Eq)]
pub struct ViewerArgs<O> {
    /// `--rrd PATH`: save the rerun recording to this file.
    pub rrd: Option<PathBuf>,
    /// `--connect [URL]`: stream to a running viewer (`""`: the default local one).
    pub connect: Option<String>,
    /// `--spawn`: start a viewer and stream to it.
    pub spawn: bool,
    /// The command's offer; `fn() -> O` keeps the flags `Send` and `Sync` whatever `O` is.
    offer: PhantomData<fn() -> O>,
}

impl<O> Default for ViewerArgs<O> {
    /// No viewer flag given.
    fn default() -> Self {
        ViewerArgs {
            rrd: None,
            connect: None,
            spawn: false,
            offer: PhantomData,
        }
    }
}

impl<O> ViewerArgs<O> {
    /// Where the data go by the flags given: a spawned viewer, else a running one, else the
    /// .rrd file; `None` when no flag was given (each command has its own default: none, or
    /// an .rrd named after the recording).
    pub fn sink(&self) -> Option<RerunSink> {
        if self.spawn {
            Some(RerunSink::Spawn)
        } else if let Some(url) = &self.connect {
            Some(RerunSink::Connect((!url.is_empty()).then(|| url.clone())))
        } else {
            self.rrd.clone().map(RerunSink::Rrd)
        }
    }

    /// Whether any viewer flag was given: each names one output, which a fleet refuses.
    pub fn is_given(&self) -> bool {
        self.rrd.is_some() || self.connect.is_some() || self.spawn
    }
}

impl<O: Offer> Args for ViewerArgs<O> {
    /// Adds the flags the command offers, with its help.
    fn augment_args(command: clap::Command) -> clap::Command {
        let (value_name, help) = O::RRD;
        let mut rrd = Arg::new("rrd")
            .long("rrd")
            .value_name(value_name)
            .help(help)
            .action(ArgAction::Set)
            .value_parser(clap::value_parser!(PathBuf));
        if O::EXCLUSIVE {
            rrd = rrd.conflicts_with("connect");
        }
        let mut command = command.arg(rrd);
        if let Some(help) = O::CONNECT {
            command = command.arg(
                Arg::new("connect")
                    .long("connect")
                    .value_name("URL")
                    .help(help)
                    .action(ArgAction::Set)
                    // A bare `--connect` is the default local viewer.
                    .num_args(0..=1)
                    .default_missing_value("")
                    .value_parser(clap::value_parser!(String)),
            );
        }
        if let Some(help) = O::SPAWN {
            command = command.arg(
                Arg::new("spawn")
                    .long("spawn")
                    .help(help)
                    .action(ArgAction::SetTrue),
            );
        }
        command
    }

    /// The same flags: none is required, so an update takes them as they are.
    fn augment_args_for_update(command: clap::Command) -> clap::Command {
        Self::augment_args(command)
    }
}

impl<O: Offer> FromArgMatches for ViewerArgs<O> {
    /// The flags as given.
    fn from_arg_matches(matches: &ArgMatches) -> Result<Self, clap::Error> {
        // A flag the command does not offer was never defined: asking clap for it would
        // panic (debug builds), so it is read only where offered.
        Ok(ViewerArgs {
            rrd: matches.get_one::<PathBuf>("rrd").cloned(),
            connect: match O::CONNECT {
                Some(_) => matches.get_one::<String>("connect").cloned(),
                None => None,
            },
            spawn: O::SPAWN.is_some() && matches.get_flag("spawn"),
            offer: PhantomData,
        })
    }

    /// The flags given here, over those given before.
    fn update_from_arg_matches(&mut self, matches: &ArgMatches) -> Result<(), clap::Error> {
        // As clap's derive updates: only what these matches hold, only flags offered.
        if matches.contains_id("rrd") {
            self.rrd = matches.get_one::<PathBuf>("rrd").cloned();
        }
        if O::CONNECT.is_some() && matches.contains_id("connect") {
            self.connect = matches.get_one::<String>("connect").cloned();
        }
        if O::SPAWN.is_some() && matches.contains_id("spawn") {
            self.spawn = matches.get_flag("spawn");
        }
        Ok(())
    }
}
