//! What an effect's parameters are, declared once next to its struct.
//!
//! Each switchable model term of the unit ([`crate::unit::Effects`]) has a
//! parameter struct declared with [`effect_params!`]: one table giving each
//! field its doc, its valid range (named as the parameter is named across
//! hpctl, e.g. `friction_coulomb_n`) and an optional default. From that one
//! table come the struct, its range checks ([`EffectParams::validate`],
//! called by [`crate::unit::Unit::new`]) and the field list the bindings
//! read and write dicts with and export to Python (where the parameter
//! dataclasses are generated from it). [`crate::unit::Effects::visit`]
//! lists the effects themselves.

use crate::error::Result;
use crate::ranges::Range;

/// One parameter of an effect.
#[derive(Debug, Clone, Copy)]
pub struct EffectField<T: 'static> {
    /// The struct field's name (and the key of the dict form).
    pub field: &'static str,
    /// What the field is (its doc comment).
    pub doc: &'static str,
    /// Its valid range, named as the parameter is across hpctl.
    pub range: Range,
    /// Its value when not given (None: required).
    pub default: Option<f64>,
    /// Reads the field.
    pub get: fn(&T) -> f64,
    /// Writes the field.
    pub set: fn(&mut T, f64),
}

/// An effect's parameter struct, as [`effect_params!`] declares it.
pub trait EffectParams: Copy + 'static {
    /// The effect's field in [`crate::unit::Effects`] (and its key in the
    /// dict form).
    const KEY: &'static str;
    /// The struct's name.
    const NAME: &'static str;
    /// What the effect is (the struct's doc comment).
    const DOC: &'static str;
    /// Every parameter, in declaration order.
    const FIELDS: &'static [EffectField<Self>];
    /// Every field 0: a start for filling the fields in one by one.
    const ZERO: Self;

    /// `Ok` if every field lies in its range, else the error naming the
    /// first that does not, its value and the range.
    fn validate(&self) -> Result<()> {
        for f in Self::FIELDS {
            f.range.check((f.get)(self))?;
        }
        Ok(())
    }
}

/// Something done to every effect slot of [`crate::unit::Effects`] (see
/// [`crate::unit::Effects::visit`]): validating, reading from and writing to
/// another representation, listing the parameters.
pub trait EffectVisitor {
    /// What stops the walk.
    type Error;
    /// Called once per effect, in declaration order.
    fn visit<T: EffectParams>(&mut self, slot: &mut Option<T>) -> core::result::Result<(), Self::Error>;
}

/// Declares an effect's parameter struct and its [`EffectParams`] table:
///
/// ```
/// use hp_core::ranges::Range;
/// hp_core::effect_params! {
///     /// A made-up effect.
///     Example = "example" {
///         /// A time constant, s.
///         time_constant_s: [Range::new("example_time_constant_s", 1e-3, 10.0), default 0.1],
///         /// A gain.
///         gain: [Range::new("example_gain", 0.0, 2.0)],
///     }
/// }
/// use hp_core::effect::EffectParams;
/// assert_eq!(Example::FIELDS.len(), 2);
/// assert!(Example { time_constant_s: 0.1, gain: 3.0 }.validate().is_err());
/// ```
#[macro_export]
macro_rules! effect_params {
    (
        $(#[doc = $doc:literal])*
        $name:ident = $key:literal {
            $(
                $(#[doc = $fdoc:literal])*
                $field:ident: [$range:expr $(, default $default:expr)?]
            ),* $(,)?
        }
    ) => {
        $(#[doc = $doc])*
        #[derive(Debug, Clone, Copy, PartialEq)]
        pub struct $name {
            $( $(#[doc = $fdoc])* pub $field: f64, )*
        }

        impl $crate::effect::EffectParams for $name {
            const KEY: &'static str = $key;
            const NAME: &'static str = stringify!($name);
            const DOC: &'static str = concat!($($doc),*);
            const FIELDS: &'static [$crate::effect::EffectField<Self>] = &[
                $(
                    $crate::effect::EffectField {
                        field: stringify!($field),
                        doc: concat!($($fdoc),*),
                        range: $range,
                        default: $crate::effect_params!(@default $($default)?),
                        get: |s: &Self| s.$field,
                        set: |s: &mut Self, v: f64| s.$field = v,
                    },
                )*
            ];
            const ZERO: Self = $name { $($field: 0.0,)* };
        }
    };
    (@default) => { None };
    (@default $default:expr) => { Some($default) };
}

#[cfg(test)]
mod tests {
    use super::{EffectParams, EffectVisitor};
    use crate::ranges::{Range, ALL};
    use crate::unit::Effects;

    /// Every effect parameter's range, with its default, in one array.
    struct Collect {
        ranges: [Option<(Range, Option<f64>)>; 64],
        n: usize,
        keys_in_order: bool,
    }

    impl EffectVisitor for Collect {
        type Error = ();
        fn visit<T: EffectParams>(&mut self, slot: &mut Option<T>) -> Result<(), ()> {
            assert!(slot.is_none());
            assert!(!T::DOC.is_empty() && !T::KEY.is_empty(), "{}", T::NAME);
            for f in T::FIELDS {
                assert!(!f.doc.is_empty(), "{}.{} has no doc", T::NAME, f.field);
                *self.ranges.get_mut(self.n).ok_or(())? = Some((f.range, f.default));
                self.n += 1;
            }
            self.keys_in_order &= !T::FIELDS.is_empty();
            Ok(())
        }
    }

    #[test]
    fn every_effect_parameter_is_named_once_with_an_ordered_range_and_a_default_inside_it() {
        let mut c = Collect { ranges: [None; 64], n: 0, keys_in_order: true };
        assert!(Effects::default().visit(&mut c).is_ok());
        assert!(c.keys_in_order && c.n > 10);
        let names: [Option<&str>; 64] = c.ranges.map(|r| r.map(|(r, _)| r.name));
        for (i, (r, default)) in c.ranges.iter().flatten().enumerate() {
            assert!(r.min <= r.max, "{}", r.name);
            assert!(ALL.iter().all(|a| a.name != r.name), "{} is in ranges::ALL too", r.name);
            assert!(names.iter().skip(i + 1).flatten().all(|n| *n != r.name), "{} twice", r.name);
            if let Some(d) = default {
                assert!(r.check(*d).is_ok(), "{}'s default {d} outside its range", r.name);
            }
        }
    }

    #[test]
    fn validate_names_the_parameter_its_value_and_range() {
        let f = crate::unit::Friction::new(-1.0, 0.0, 1e-3);
        let e = f.validate();
        assert!(
            matches!(e, Err(crate::error::Error::OutOfRange { name: "friction_coulomb_n", value, min, max }) if value == -1.0 && min == 0.0 && max == 1e6),
            "{e:?}"
        );
    }
}
