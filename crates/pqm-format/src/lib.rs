//! The `.pqm` file format (see `spec/pqm.md`): writer, reader and streaming decoder.
