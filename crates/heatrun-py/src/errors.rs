//! The library's errors as Python exceptions, with the command line's one-line message.

use pyo3::create_exception;
use pyo3::exceptions::PyException;
use pyo3::PyErr;

create_exception!(
    _heatrun,
    HeatrunError,
    PyException,
    "An error of heatrun's library, with the command line's one-line message."
);
create_exception!(
    _heatrun,
    BadInputError,
    HeatrunError,
    "The input's fault (a bad file, channel, row, key or option): the command line's exit status 2."
);

/// The error as one line, as the command line prints it: its message, then each cause
/// whose text the message does not already hold (the library's messages carry their
/// causes).
pub fn one_line(error: &(dyn std::error::Error + 'static)) -> String {
    let mut line = String::new();
    let mut cause = Some(error);
    while let Some(e) = cause {
        let text = e.to_string();
        if !line.contains(&text) {
            if !line.is_empty() {
                line.push_str(": ");
            }
            line.push_str(&text);
        }
        cause = e.source();
    }
    line
}

/// The exception of a library error: [`BadInputError`] where the command line would exit
/// with status 2, else [`HeatrunError`].
pub fn to_py(error: heatrun::Error) -> PyErr {
    let message = one_line(&error);
    if error.is_bad_input() {
        BadInputError::new_err(message)
    } else {
        HeatrunError::new_err(message)
    }
}

/// A bad option, named as the command line's flag would be.
pub fn bad_input(message: impl Into<String>) -> PyErr {
    BadInputError::new_err(message.into())
}
