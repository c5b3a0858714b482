//! Training: the classifiers' augmentation ([`augment`]), SNN recipes ([`recipe`]) and the keys that set them ([`settings`]), fitting an SNN on simulated windows or a tactile dataset
//! ([`fit`]), the validation-driven search on any dataset folder ([`search`], run whole by
//! [`search::run`]), the linear floors ([`baselines`]), the conventional networks chosen by the same
//! protocol ([`networks`]) and the ResNet's training ([`resnet`]); one run as the command line asks for it ([`job`]).

pub mod augment;
pub mod baselines;
pub mod fit;
pub mod job;
pub mod networks;
pub mod recipe;
pub mod resnet;
pub mod search;
pub mod settings;
