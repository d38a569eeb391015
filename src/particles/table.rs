//! The macro that turns the particle field table (in `particles/mod.rs`) into the store.
//!
//! From one list of fields it derives: the structure of arrays [`super::Particles`], one
//! particle's [`super::Record`] (the wire record of halos, migration and gathers), push,
//! truncate and permute, the [`super::Fields`] flags with partial records for ghost refreshes,
//! the byte counts, the field metadata (units, names) and the typed columns output writers
//! read. Adding a field is one entry in the table.

/// Expands the field table; see `particles/mod.rs` for the one invocation.
macro_rules! particle_table {
    (
        shared {
            $(
                $(#[doc = $doc:literal])*
                $([cfg($cfg:meta)])?
                $name:ident / $flag:ident : $ty:ty {
                    image: $img:ident,
                    csv: $csv:expr,
                    snapshot: $snap:expr,
                    unit: $unit:literal,
                    long_name: $long:literal $(,)?
                }
            )*
        }
        owned {
            $( $(#[doc = $odoc:literal])* $oname:ident : $oty:ty; )*
        }
    ) => {
        /// Bit positions of the shared fields in [`Fields`].
        #[allow(non_camel_case_types, dead_code)]
        #[derive(Clone, Copy)]
        #[repr(u32)]
        enum FieldIndex {
            $( $(#[cfg($cfg)])? $name, )*
        }

        impl Fields {
            $(
                $(#[cfg($cfg)])?
                #[doc = concat!("Flag of the field `", stringify!($name), "`.")]
                pub const $flag: Fields = Fields(1 << FieldIndex::$name as u32);
            )*
        }

        /// Particle fields (structure of arrays): owned particles first, then ghosts. Shared
        /// fields exist for every particle and travel in records; owned-only fields (rates)
        /// exist for owned particles only.
        #[derive(Debug, Clone, Default)]
        pub struct Particles<const D: usize> {
            /// Number of owned particles; the rest are ghosts.
            pub n_owned: usize,
            /// Shared fields this store does not hold (a fluid-only run drops the solid
            /// fields): no storage, never sent, read as zero by [`Particles::record`].
            pub dropped: Fields,
            /// A gathered view's store (output, probes: [`Particles::for_view`]), never
            /// stepped: it holds no owned-only columns (rates).
            pub view_only: bool,
            $( $(#[doc = $doc])* $(#[cfg($cfg)])? pub $name: Vec<$ty>, )*
            $( $(#[doc = $odoc])* pub $oname: Vec<$oty>, )*
        }

        /// One particle's shared fields: what halos, migration and gathers send.
        #[derive(Debug, Clone, Copy, PartialEq)]
        pub struct Record<const D: usize> {
            $( $(#[doc = $doc])* $(#[cfg($cfg)])? pub $name: $ty, )*
        }

        impl<const D: usize> Default for Record<D> {
            fn default() -> Self {
                Record { $( $(#[cfg($cfg)])? $name: <$ty as FieldValue<D>>::zero(), )* }
            }
        }

        impl<const D: usize> Record<D> {
            /// Write the whole record.
            #[inline]
            pub fn put(&self, s: &mut impl Sink) {
                $( $(#[cfg($cfg)])? <$ty as FieldValue<D>>::put(&self.$name, s); )*
                s.end();
            }

            /// Read a whole record.
            #[inline]
            pub fn get(r: &mut Reader) -> Result<Self> {
                let rec = Record { $( $(#[cfg($cfg)])? $name: <$ty as FieldValue<D>>::get(r)?, )* };
                r.end();
                Ok(rec)
            }

            /// This record seen through an image operation (each field by its rule).
            #[inline]
            pub fn imaged(&self, im: &impl Imager<D>) -> Self {
                Record {
                    $( $(#[cfg($cfg)])? $name: <$ty as FieldValue<D>>::imaged(&self.$name, ImageRule::$img, im), )*
                }
            }

            /// Write the record without the `dropped` fields (what halos, migration and
            /// gathers send).
            #[inline]
            pub fn put_carried(&self, dropped: Fields, s: &mut impl Sink) {
                $(
                    $(#[cfg($cfg)])?
                    if !dropped.has(Fields::$flag) {
                        <$ty as FieldValue<D>>::put(&self.$name, s);
                    }
                )*
                s.end();
            }

            /// Read a record written by [`Record::put_carried`] with the same `dropped`
            /// fields (which read as zero).
            #[inline]
            pub fn get_carried(dropped: Fields, r: &mut Reader) -> Result<Self> {
                #[allow(unused_mut)]
                let mut rec = Record::default();
                $(
                    $(#[cfg($cfg)])?
                    if !dropped.has(Fields::$flag) {
                        rec.$name = <$ty as FieldValue<D>>::get(r)?;
                    }
                )*
                r.end();
                Ok(rec)
            }

            /// 8-byte words of a record without the `dropped` fields.
            pub fn words_carried(dropped: Fields) -> usize {
                let mut c = Count::default();
                Self::default().put_carried(dropped, &mut c);
                c.words
            }

            /// 8-byte words of a whole record.
            pub fn words() -> usize {
                let mut c = Count::default();
                Self::default().put(&mut c);
                c.words
            }
        }

        impl<const D: usize> Particles<D> {
            /// Bytes the store's columns hold, by their capacities (`summary.json`'s memory
            /// parts).
            pub fn bytes_held(&self) -> usize {
                let mut b = 0;
                $(
                    $(#[cfg($cfg)])?
                    {
                        b += self.$name.capacity() * std::mem::size_of::<$ty>();
                    }
                )*
                $( b += self.$oname.capacity() * std::mem::size_of::<$oty>(); )*
                b
            }

            /// Drop every ghost, keeping owned particles.
            pub fn truncate_ghosts(&mut self) {
                let n = self.n_owned;
                $( $(#[cfg($cfg)])? self.$name.truncate(n); )*
            }

            /// Reorder (or select) the owned particles (ghosts must have been dropped): new
            /// particle k is old particle `perm[k]`; particles not listed are dropped. Results
            /// never depend on local order (sums follow global keys), so reordering only
            /// changes memory locality.
            pub fn permute_owned(&mut self, perm: &[usize]) {
                debug_assert_eq!(self.len(), self.n_owned, "drop ghosts before permuting");
                self.n_owned = perm.len();
                fn gather<T: Copy>(v: &mut Vec<T>, perm: &[usize]) {
                    let old = std::mem::take(v);
                    v.extend(perm.iter().map(|&i| old[i]));
                }
                $(
                    $(#[cfg($cfg)])?
                    if !self.dropped.has(Fields::$flag) {
                        gather(&mut self.$name, perm);
                    }
                )*
                if !self.view_only {
                    $( gather(&mut self.$oname, perm); )*
                }
            }

            /// The shared fields of particle `i`.
            #[inline]
            pub fn record(&self, i: usize) -> Record<D> {
                Record {
                    $(
                        $(#[cfg($cfg)])?
                        $name: if self.dropped.has(Fields::$flag) {
                            <$ty as FieldValue<D>>::zero()
                        } else {
                            self.$name[i]
                        },
                    )*
                }
            }

            #[inline]
            fn push_shared(&mut self, r: &Record<D>) {
                $(
                    $(#[cfg($cfg)])?
                    if !self.dropped.has(Fields::$flag) {
                        self.$name.push(r.$name);
                    }
                )*
            }

            #[inline]
            fn push_rates(&mut self) {
                if !self.view_only {
                    $( self.$oname.push(<$oty as FieldValue<D>>::zero()); )*
                }
            }

            /// Room for `n` more particles in every column this store keeps.
            pub fn reserve(&mut self, n: usize) {
                $(
                    $(#[cfg($cfg)])?
                    if !self.dropped.has(Fields::$flag) {
                        self.$name.reserve(n);
                    }
                )*
                if !self.view_only {
                    $( self.$oname.reserve(n); )*
                }
            }

            /// Room for `n` more particles in every column this store keeps, a column that
            /// lacks it growing to an eighth more than it needs rather than doubling: the
            /// ghosts a halo appends would otherwise double every column of a table whose
            /// owned rows fill it (3 ranks of the 3D DualSPHysics dam break: 1.8 × the owned
            /// rows' bytes).
            pub fn grow_for(&mut self, n: usize) {
                fn grow<T>(v: &mut Vec<T>, n: usize) {
                    let need = v.len() + n;
                    if v.capacity() < need {
                        v.reserve_exact(need + need / 8 - v.len());
                    }
                }
                $(
                    $(#[cfg($cfg)])?
                    if !self.dropped.has(Fields::$flag) {
                        grow(&mut self.$name, n);
                    }
                )*
                if !self.view_only {
                    $( grow(&mut self.$oname, n); )*
                }
            }

            /// Write the `fields` of particle `i` seen through `im` (a ghost refresh record).
            #[inline]
            pub fn put_fields(&self, i: usize, fields: Fields, im: &impl Imager<D>, s: &mut impl Sink) {
                $(
                    $(#[cfg($cfg)])?
                    if fields.has(Fields::$flag) {
                        let v = <$ty as FieldValue<D>>::imaged(&self.$name[i], ImageRule::$img, im);
                        <$ty as FieldValue<D>>::put(&v, s);
                    }
                )*
                s.end();
            }

            /// Read the `fields` of ghost `g` written by [`Particles::put_fields`].
            #[inline]
            pub fn get_fields(&mut self, g: usize, fields: Fields, r: &mut Reader) -> Result<()> {
                $(
                    $(#[cfg($cfg)])?
                    if fields.has(Fields::$flag) {
                        self.$name[g] = <$ty as FieldValue<D>>::get(r)?;
                    }
                )*
                r.end();
                Ok(())
            }

            /// 8-byte words of a partial record holding `fields`.
            pub fn field_words(fields: Fields) -> usize {
                let mut c = Count::default();
                $(
                    $(#[cfg($cfg)])?
                    if fields.has(Fields::$flag) {
                        <$ty as FieldValue<D>>::put(&<$ty as FieldValue<D>>::zero(), &mut c);
                    }
                )*
                c.end();
                c.words
            }

            /// Bytes per particle of this store, shared and owned-only fields (for memory
            /// estimates; a ghost costs the shared part only).
            pub fn bytes_per_particle() -> usize {
                Self::bytes_per_particle_carried(Fields::NONE)
            }

            /// Bytes per particle of a store without the `dropped` fields.
            pub fn bytes_per_particle_carried(dropped: Fields) -> usize {
                Self::bytes_per_ghost_carried(dropped) $( + std::mem::size_of::<$oty>() )*
            }

            /// Bytes per ghost: the shared fields only.
            pub fn bytes_per_ghost() -> usize {
                Self::bytes_per_ghost_carried(Fields::NONE)
            }

            /// Bytes per ghost of a store without the `dropped` fields.
            pub fn bytes_per_ghost_carried(dropped: Fields) -> usize {
                let mut b = 0;
                $(
                    $(#[cfg($cfg)])?
                    if !dropped.has(Fields::$flag) {
                        b += std::mem::size_of::<$ty>();
                    }
                )*
                b
            }

            /// Every shared field's metadata, in table order.
            #[allow(clippy::vec_init_then_push)]
            pub fn field_table() -> Vec<FieldMeta> {
                #[allow(unused_mut)]
                let mut v = Vec::new();
                $(
                    $(#[cfg($cfg)])?
                    v.push(FieldMeta {
                        name: stringify!($name),
                        flag: Fields::$flag,
                        csv: $csv,
                        snapshot: $snap,
                        unit: $unit,
                        long_name: $long,
                    });
                )*
                v
            }

            /// A shared field by its table name, as a typed column.
            pub fn column(&self, name: &str) -> Option<Column<'_, D>> {
                $(
                    $(#[cfg($cfg)])?
                    if name == stringify!($name) {
                        if self.dropped.has(Fields::$flag) {
                            return None;
                        }
                        return Some(<$ty as FieldValue<D>>::column(&self.$name));
                    }
                )*
                None
            }
        }
    };
}

pub(crate) use particle_table;
